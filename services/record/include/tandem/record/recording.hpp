// A recording of a tandem run: an MCAP file (mcap.hpp) whose messages are Protobuf (idl/tandem_record.proto).
// The writer registers one schema per message type, holding the serialized FileDescriptorSet of the schema
// file, so that any MCAP reader (Foxglove Studio, the mcap CLI, @mcap/core with protobufjs) decodes the
// messages without this project's code. docs/recording.md has the channels and what each carries.
#pragma once

#include <google/protobuf/message.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "tandem/record/mcap.hpp"

namespace tandem::record {

/// The serialized FileDescriptorSet of the file that defines `d` (with the files it imports, dependencies first).
std::string file_descriptor_set(const google::protobuf::Descriptor* d);

/// Nanoseconds since the Unix epoch (the log time of live recordings).
inline uint64_t now_ns() {
  return static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

/// An MCAP writer that knows Protobuf: channels by topic and message type, messages serialized on write.
class RecordingWriter {
 public:
  explicit RecordingWriter(const std::string& path, McapWriter::Options opt = {});
  /// The channel of `topic` carrying messages of type `d` (created on first use; one schema per type).
  uint16_t channel(const std::string& topic, const google::protobuf::Descriptor* d,
                   const std::map<std::string, std::string>& metadata = {});
  void write(uint16_t channel, const google::protobuf::Message& m, uint64_t log_time_ns, uint64_t publish_time_ns = 0);
  void metadata(const std::string& name, const std::map<std::string, std::string>& values) { w_.add_metadata(name, values); }
  void flush() { w_.flush_chunk(); }
  void close() { w_.close(); }
  uint64_t messages() const { return w_.messages(); }
  uint64_t bytes() const { return w_.bytes_written(); }

 private:
  McapWriter w_;
  std::map<std::string, uint16_t> schemas_;   ///< full message name -> schema id
  std::map<std::string, uint16_t> channels_;  ///< topic -> channel id
  std::string buf_;
};

}  // namespace tandem::record
