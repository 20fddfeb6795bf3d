#include "tandem/record/recording.hpp"

#include <google/protobuf/descriptor.pb.h>

#include <set>
#include <stdexcept>

namespace tandem::record {

namespace {
void add_file(const google::protobuf::FileDescriptor* f, google::protobuf::FileDescriptorSet& set,
              std::set<std::string>& seen) {
  if (!seen.insert(f->name()).second) return;
  for (int i = 0; i < f->dependency_count(); ++i) add_file(f->dependency(i), set, seen);
  f->CopyTo(set.add_file());
}
}  // namespace

std::string file_descriptor_set(const google::protobuf::Descriptor* d) {
  google::protobuf::FileDescriptorSet set;
  std::set<std::string> seen;
  add_file(d->file(), set, seen);
  return set.SerializeAsString();
}

RecordingWriter::RecordingWriter(const std::string& path, McapWriter::Options opt) : w_(path, std::move(opt)) {}

uint16_t RecordingWriter::channel(const std::string& topic, const google::protobuf::Descriptor* d,
                                  const std::map<std::string, std::string>& metadata) {
  const auto c = channels_.find(topic);
  if (c != channels_.end()) return c->second;
  auto s = schemas_.find(d->full_name());
  if (s == schemas_.end()) {
    s = schemas_.emplace(d->full_name(), w_.add_schema(d->full_name(), "protobuf", file_descriptor_set(d))).first;
  }
  const uint16_t id = w_.add_channel(s->second, topic, "protobuf", metadata);
  channels_[topic] = id;
  return id;
}

void RecordingWriter::write(uint16_t channel, const google::protobuf::Message& m, uint64_t log_time_ns,
                            uint64_t publish_time_ns) {
  buf_.clear();
  if (!m.SerializeToString(&buf_)) throw std::runtime_error("cannot serialize a " + m.GetTypeName());
  w_.write(channel, log_time_ns, publish_time_ns == 0 ? log_time_ns : publish_time_ns, buf_.data(), buf_.size());
}

}  // namespace tandem::record
