// The MCAP container (https://mcap.dev/spec, format version 0), written and read by the project's own code:
// no Debian package ships it. The writer puts messages into uncompressed chunks with a CRC, a message index
// per channel after every chunk, and a summary section (schemas, channels, statistics, chunk and metadata
// indexes, summary offsets) so that a reader can seek. The reader reads the file from start to end: it checks
// every record's length, the records a chunk may hold, the chunk, data and summary CRCs and the statistics, and
// reports where a file is corrupt or truncated; index records (message, chunk, metadata indexes, summary
// offsets) it skips, as it does not seek. Nothing here knows the message encoding (docs/recording.md).
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace tandem::record {

/// CRC-32 (ISO-HDLC, the one MCAP and zlib use), continued from `crc` (0 to start).
uint32_t crc32(const void* data, size_t n, uint32_t crc = 0);

/// A file that is not valid MCAP: the message names the file, the byte offset and what was wrong.
struct McapError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct McapSchema {
  uint16_t id = 0;
  std::string name, encoding, data;
};

struct McapChannel {
  uint16_t id = 0, schema_id = 0;
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};

struct McapMetadata {
  std::string name;
  std::map<std::string, std::string> values;
};

class McapWriter {
 public:
  struct Options {
    size_t chunk_size = 1 << 20;  ///< a chunk is closed once its records pass this many bytes
    std::string profile;          ///< "" (none) or e.g. "ros2"
    std::string library = "tandem";
  };
  /// Creates (truncates) `path`. Throws std::runtime_error if it cannot be opened.
  McapWriter(const std::string& path, Options opt);
  explicit McapWriter(const std::string& path) : McapWriter(path, Options{}) {}
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  uint16_t add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                       const std::map<std::string, std::string>& metadata = {});
  /// One message; sequence counts per channel. Throws std::runtime_error for an unknown channel.
  void write(uint16_t channel, uint64_t log_time_ns, uint64_t publish_time_ns, const void* data, size_t n);
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values);
  /// Closes the open chunk and writes the summary and footer. Idempotent; also done by the destructor.
  /// Throws std::runtime_error if the file could not be written completely.
  void close();
  /// Writes the open chunk out now (so that a crash loses at most what came after).
  void flush_chunk();

  uint64_t messages() const { return message_count_; }
  uint64_t bytes_written() const { return offset_; }

 private:
  void put(const std::string& bytes, bool data_section = true);
  void put_record_in_chunk(const std::string& record);

  std::FILE* f_ = nullptr;
  std::string path_;
  Options opt_;
  uint64_t offset_ = 0;
  uint32_t data_crc_ = 0;
  bool closed_ = false, failed_ = false;
  // The open chunk.
  std::string chunk_;
  uint64_t chunk_start_ = 0, chunk_end_ = 0;
  bool chunk_has_messages_ = false;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_index_;  ///< channel -> (log time, offset)
  // Summary.
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::map<uint16_t, uint32_t> sequence_;
  std::map<uint16_t, uint64_t> channel_counts_;
  std::string chunk_indexes_, metadata_indexes_;
  uint64_t message_count_ = 0, message_start_ = 0, message_end_ = 0;
  uint32_t chunk_count_ = 0, metadata_count_ = 0;
  std::vector<std::string> pending_defs_;  ///< schema/channel records to repeat in the next chunk
};

/// What a reader found besides the messages.
struct McapInfo {
  std::string profile, library;
  std::map<uint16_t, McapSchema> schemas;
  std::map<uint16_t, McapChannel> channels;
  std::vector<McapMetadata> metadata;
  uint64_t messages = 0, chunks = 0;
  bool summary = false;          ///< a footer and summary section were found and checked
  bool salvaged = false;         ///< the file was cut short; what came before the damage was read
  std::string damage;            ///< salvage: what was wrong and where
};

struct McapMessageView {
  const McapChannel* channel = nullptr;
  uint32_t sequence = 0;
  uint64_t log_time = 0, publish_time = 0;
  const char* data = nullptr;
  size_t size = 0;
};

/// Reads `path` from start to end, calling `on_message` for every message in file order. Checks magic, every
/// record's length, chunk CRCs, the data section CRC, the footer and the summary CRC. Throws McapError naming
/// the offset and the fault; with `salvage`, a file that is cut short or damaged gives the messages of every
/// complete, intact chunk before the damage instead (McapInfo::salvaged/damage say so).
McapInfo read_mcap(const std::string& path, const std::function<void(const McapMessageView&)>& on_message,
                   bool salvage = false);

}  // namespace tandem::record
