#include "tandem/record/mcap.hpp"

#include <zlib.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstring>

namespace tandem::record {

namespace {

constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kMetadata = 0x0C, kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E, kDataEnd = 0x0F,
};

const char* op_name(uint8_t op) {
  switch (op) {
    case kHeader: return "Header";
    case kFooter: return "Footer";
    case kSchema: return "Schema";
    case kChannel: return "Channel";
    case kMessage: return "Message";
    case kChunk: return "Chunk";
    case kMessageIndex: return "MessageIndex";
    case kChunkIndex: return "ChunkIndex";
    case 0x09: return "Attachment";
    case 0x0A: return "AttachmentIndex";
    case kStatistics: return "Statistics";
    case kMetadata: return "Metadata";
    case kMetadataIndex: return "MetadataIndex";
    case kSummaryOffset: return "SummaryOffset";
    case kDataEnd: return "DataEnd";
    default: return "unknown";
  }
}

// Little-endian encoders (MCAP is little-endian throughout).
void u8(std::string& b, uint8_t v) { b.push_back(static_cast<char>(v)); }
template <class T>
void le(std::string& b, T v) {
  for (size_t i = 0; i < sizeof(T); ++i) b.push_back(static_cast<char>((static_cast<uint64_t>(v) >> (8 * i)) & 0xFF));
}
void str(std::string& b, const std::string& s) {
  le<uint32_t>(b, static_cast<uint32_t>(s.size()));
  b += s;
}
void str_map(std::string& b, const std::map<std::string, std::string>& m) {
  std::string body;
  for (const auto& [k, v] : m) {
    str(body, k);
    str(body, v);
  }
  le<uint32_t>(b, static_cast<uint32_t>(body.size()));
  b += body;
}
std::string record(uint8_t op, const std::string& content) {
  std::string r;
  r.reserve(9 + content.size());
  u8(r, op);
  le<uint64_t>(r, content.size());
  r += content;
  return r;
}

}  // namespace

uint32_t crc32(const void* data, size_t n, uint32_t crc) {
  // zlib's CRC-32 (the same polynomial as MCAP's), fed in blocks that fit its uInt length.
  const auto* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (n > 0) {
    const uInt len = static_cast<uInt>(std::min<size_t>(n, 1U << 30));
    c = ::crc32(c, p, len);
    p += len;
    n -= len;
  }
  return static_cast<uint32_t>(c);
}

// ---------------------------------------------------------------------------------------------- writer

McapWriter::McapWriter(const std::string& path, Options opt) : path_(path), opt_(std::move(opt)) {
  f_ = std::fopen(path.c_str(), "wb");
  if (f_ == nullptr) throw std::runtime_error(path + ": cannot create the recording: " + std::strerror(errno));
  put(std::string(kMagic, 8));
  std::string h;
  str(h, opt_.profile);
  str(h, opt_.library);
  put(record(kHeader, h));
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (...) {  // a destructor does not throw; close() explicitly to hear about a failed write
  }
}

void McapWriter::put(const std::string& bytes, bool data_section) {
  if (f_ == nullptr) return;
  if (std::fwrite(bytes.data(), 1, bytes.size(), f_) != bytes.size()) failed_ = true;
  if (data_section) data_crc_ = crc32(bytes.data(), bytes.size(), data_crc_);
  offset_ += bytes.size();
}

void McapWriter::put_record_in_chunk(const std::string& rec) { chunk_ += rec; }

uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (closed_) throw std::runtime_error(path_ + ": recording closed");
  McapSchema s{static_cast<uint16_t>(schemas_.size() + 1), name, encoding, data};
  std::string c;
  le<uint16_t>(c, s.id);
  str(c, name);
  str(c, encoding);
  str(c, data);  // bytes: u32 length prefix, like a string
  put_record_in_chunk(record(kSchema, c));
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

uint16_t McapWriter::add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                                 const std::map<std::string, std::string>& metadata) {
  if (closed_) throw std::runtime_error(path_ + ": recording closed");
  if (schema_id == 0 || schema_id > schemas_.size()) throw std::runtime_error("add_channel: unknown schema id");
  McapChannel ch{static_cast<uint16_t>(channels_.size() + 1), schema_id, topic, message_encoding, metadata};
  std::string c;
  le<uint16_t>(c, ch.id);
  le<uint16_t>(c, schema_id);
  str(c, topic);
  str(c, message_encoding);
  str_map(c, metadata);
  put_record_in_chunk(record(kChannel, c));
  channels_.push_back(std::move(ch));
  return channels_.back().id;
}

void McapWriter::write(uint16_t channel, uint64_t log_time_ns, uint64_t publish_time_ns, const void* data, size_t n) {
  if (closed_) throw std::runtime_error(path_ + ": recording closed");
  if (channel == 0 || channel > channels_.size()) throw std::runtime_error("write: unknown channel id");
  const uint64_t at = chunk_.size();
  u8(chunk_, kMessage);
  le<uint64_t>(chunk_, 2 + 4 + 8 + 8 + n);
  le<uint16_t>(chunk_, channel);
  le<uint32_t>(chunk_, sequence_[channel]++);
  le<uint64_t>(chunk_, log_time_ns);
  le<uint64_t>(chunk_, publish_time_ns);
  chunk_.append(static_cast<const char*>(data), n);
  chunk_index_[channel].emplace_back(log_time_ns, at);
  if (!chunk_has_messages_) {
    chunk_start_ = chunk_end_ = log_time_ns;
    chunk_has_messages_ = true;
  }
  chunk_start_ = std::min(chunk_start_, log_time_ns);
  chunk_end_ = std::max(chunk_end_, log_time_ns);
  if (message_count_ == 0) message_start_ = message_end_ = log_time_ns;
  message_start_ = std::min(message_start_, log_time_ns);
  message_end_ = std::max(message_end_, log_time_ns);
  ++message_count_;
  ++channel_counts_[channel];
  if (chunk_.size() >= opt_.chunk_size) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (!chunk_has_messages_ || f_ == nullptr) return;
  const uint64_t chunk_offset = offset_;
  std::string c;
  le<uint64_t>(c, chunk_start_);
  le<uint64_t>(c, chunk_end_);
  le<uint64_t>(c, chunk_.size());
  le<uint32_t>(c, crc32(chunk_.data(), chunk_.size()));
  str(c, "");  // no compression
  le<uint64_t>(c, chunk_.size());
  c += chunk_;
  const std::string rec = record(kChunk, c);
  put(rec);
  const uint64_t index_start = offset_;
  std::map<uint16_t, uint64_t> index_offsets;
  for (const auto& [ch, entries] : chunk_index_) {
    std::string m;
    le<uint16_t>(m, ch);
    le<uint32_t>(m, static_cast<uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      le<uint64_t>(m, t);
      le<uint64_t>(m, off);
    }
    index_offsets[ch] = offset_;
    put(record(kMessageIndex, m));
  }
  std::string ci;
  le<uint64_t>(ci, chunk_start_);
  le<uint64_t>(ci, chunk_end_);
  le<uint64_t>(ci, chunk_offset);
  le<uint64_t>(ci, rec.size());
  std::string offs;
  for (const auto& [ch, off] : index_offsets) {
    le<uint16_t>(offs, ch);
    le<uint64_t>(offs, off);
  }
  le<uint32_t>(ci, static_cast<uint32_t>(offs.size()));
  ci += offs;
  le<uint64_t>(ci, offset_ - index_start);
  str(ci, "");
  le<uint64_t>(ci, chunk_.size());  // compressed size (= uncompressed: none)
  le<uint64_t>(ci, chunk_.size());
  chunk_indexes_ += record(kChunkIndex, ci);
  ++chunk_count_;
  chunk_.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
  if (std::fflush(f_) != 0) failed_ = true;
}

void McapWriter::add_metadata(const std::string& name, const std::map<std::string, std::string>& values) {
  if (closed_) throw std::runtime_error(path_ + ": recording closed");
  std::string c;
  str(c, name);
  str_map(c, values);
  const std::string rec = record(kMetadata, c);
  const uint64_t at = offset_;
  put(rec);
  std::string mi;
  le<uint64_t>(mi, at);
  le<uint64_t>(mi, rec.size());
  str(mi, name);
  metadata_indexes_ += record(kMetadataIndex, mi);
  ++metadata_count_;
}

void McapWriter::close() {
  if (closed_ || f_ == nullptr) return;
  flush_chunk();
  if (!chunk_.empty()) {  // schema/channel records and no message since: outside any chunk
    put(chunk_);
    chunk_.clear();
  }
  closed_ = true;
  std::string de;
  le<uint32_t>(de, data_crc_);
  put(record(kDataEnd, de), false);

  const uint64_t summary_start = offset_;
  uint32_t summary_crc = 0;
  auto put_summary = [&](const std::string& bytes) {
    summary_crc = crc32(bytes.data(), bytes.size(), summary_crc);
    put(bytes, false);
  };
  std::string offsets;  // SummaryOffset records, one per group
  auto group = [&](uint8_t op, const std::string& bytes) {
    if (bytes.empty()) return;
    std::string so;
    u8(so, op);
    le<uint64_t>(so, offset_);
    le<uint64_t>(so, bytes.size());
    offsets += record(kSummaryOffset, so);
    put_summary(bytes);
  };
  std::string schemas, channels;
  for (const auto& s : schemas_) {
    std::string c;
    le<uint16_t>(c, s.id);
    str(c, s.name);
    str(c, s.encoding);
    str(c, s.data);
    schemas += record(kSchema, c);
  }
  for (const auto& ch : channels_) {
    std::string c;
    le<uint16_t>(c, ch.id);
    le<uint16_t>(c, ch.schema_id);
    str(c, ch.topic);
    str(c, ch.message_encoding);
    str_map(c, ch.metadata);
    channels += record(kChannel, c);
  }
  std::string st;
  le<uint64_t>(st, message_count_);
  le<uint16_t>(st, static_cast<uint16_t>(schemas_.size()));
  le<uint32_t>(st, static_cast<uint32_t>(channels_.size()));
  le<uint32_t>(st, 0U);  // attachments
  le<uint32_t>(st, metadata_count_);
  le<uint32_t>(st, chunk_count_);
  le<uint64_t>(st, message_start_);
  le<uint64_t>(st, message_end_);
  std::string counts;
  for (const auto& [ch, n] : channel_counts_) {
    le<uint16_t>(counts, ch);
    le<uint64_t>(counts, n);
  }
  le<uint32_t>(st, static_cast<uint32_t>(counts.size()));
  st += counts;
  group(kSchema, schemas);
  group(kChannel, channels);
  group(kStatistics, record(kStatistics, st));
  group(kChunkIndex, chunk_indexes_);
  group(kMetadataIndex, metadata_indexes_);
  const uint64_t summary_offset_start = offset_;
  put_summary(offsets);
  std::string footer;
  u8(footer, kFooter);
  le<uint64_t>(footer, 8 + 8 + 4);
  le<uint64_t>(footer, summary_start);
  le<uint64_t>(footer, summary_offset_start);
  summary_crc = crc32(footer.data(), footer.size(), summary_crc);
  le<uint32_t>(footer, summary_crc);
  put(footer, false);
  put(std::string(kMagic, 8), false);
  const bool flushed = std::fflush(f_) == 0 && ::fsync(fileno(f_)) == 0;
  const bool closed = std::fclose(f_) == 0;
  f_ = nullptr;
  if (failed_ || !flushed || !closed) throw std::runtime_error(path_ + ": the recording could not be written completely");
}

// ---------------------------------------------------------------------------------------------- reader

namespace {

// A bounds-checked cursor over one record's content.
class Cursor {
 public:
  Cursor(const char* p, size_t n, uint64_t base, const std::string& where) : p_(p), n_(n), base_(base), where_(where) {}
  template <class T>
  T get() {
    need(sizeof(T));
    uint64_t v = 0;
    for (size_t i = 0; i < sizeof(T); ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(p_[i_ + i])) << (8 * i);
    i_ += sizeof(T);
    return static_cast<T>(v);
  }
  std::string str() {
    const uint32_t n = get<uint32_t>();
    need(n);
    std::string s(p_ + i_, n);
    i_ += n;
    return s;
  }
  std::map<std::string, std::string> str_map() {
    const uint32_t n = get<uint32_t>();
    need(n);
    Cursor sub(p_ + i_, n, base_ + i_, where_);
    i_ += n;
    std::map<std::string, std::string> m;
    while (!sub.done()) {
      std::string k = sub.str();
      m[k] = sub.str();
    }
    return m;
  }
  const char* take(uint64_t n) {
    need(n);
    const char* p = p_ + i_;
    i_ += n;
    return p;
  }
  size_t left() const { return n_ - i_; }
  bool done() const { return i_ >= n_; }
  uint64_t at() const { return base_ + i_; }

 private:
  void need(uint64_t k) const {
    if (k > n_ - i_) {
      throw McapError(where_ + ": field at byte " + std::to_string(base_ + i_) + " runs past the end of its record");
    }
  }
  const char* p_;
  size_t n_, i_ = 0;
  uint64_t base_;
  std::string where_;
};

struct Mapped {
  const char* p = nullptr;
  size_t n = 0;
  int fd = -1;
  ~Mapped() {
    if (p != nullptr && n > 0) ::munmap(const_cast<char*>(p), n);
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

McapInfo read_mcap(const std::string& path, const std::function<void(const McapMessageView&)>& on_message,
                   bool salvage) {
  Mapped m;
  m.fd = ::open(path.c_str(), O_RDONLY);
  if (m.fd < 0) throw McapError(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(m.fd, &st) != 0 || !S_ISREG(st.st_mode)) throw McapError(path + ": not a regular file");
  m.n = static_cast<size_t>(st.st_size);
  if (m.n > 0) {
    void* p = ::mmap(nullptr, m.n, PROT_READ, MAP_PRIVATE, m.fd, 0);
    if (p == MAP_FAILED) throw McapError(path + ": cannot map: " + std::strerror(errno));
    m.p = static_cast<const char*>(p);
  }
  if (m.n < 8 || std::memcmp(m.p, kMagic, 8) != 0) {
    throw McapError(path + ": not an MCAP file (" + (m.n < 8 ? std::to_string(m.n) + " bytes long" : "no MCAP magic at byte 0") +
                    "; an MCAP file starts with \\x89MCAP0\\r\\n)");
  }
  McapInfo info;
  const std::string where = path;
  uint64_t pos = 8;
  bool data_end = false, footer = false, header = false;
  uint64_t summary_messages = 0;
  bool have_stats = false;
  uint64_t chunk_indexes = 0;

  auto message = [&](Cursor& c, uint64_t at) {
    McapMessageView v;
    const uint16_t ch = c.get<uint16_t>();
    const auto it = info.channels.find(ch);
    if (it == info.channels.end()) {
      throw McapError(where + ": message at byte " + std::to_string(at) + " is on channel " + std::to_string(ch) +
                      ", which no Channel record defined before it");
    }
    v.channel = &it->second;
    v.sequence = c.get<uint32_t>();
    v.log_time = c.get<uint64_t>();
    v.publish_time = c.get<uint64_t>();
    v.size = c.left();
    v.data = c.take(v.size);
    ++info.messages;
    on_message(v);
  };
  auto schema = [&](Cursor& c, bool summary) {
    McapSchema s;
    s.id = c.get<uint16_t>();
    s.name = c.str();
    s.encoding = c.str();
    s.data = c.str();
    if (s.id == 0) throw McapError(where + ": schema with id 0 (reserved) at byte " + std::to_string(c.at()));
    const auto it = info.schemas.find(s.id);
    if (it != info.schemas.end() && (it->second.name != s.name || it->second.data != s.data)) {
      throw McapError(where + ": schema " + std::to_string(s.id) + " is defined twice, differently" +
                      (summary ? " (data section and summary)" : ""));
    }
    info.schemas[s.id] = std::move(s);
  };
  auto channel = [&](Cursor& c) {
    McapChannel ch;
    ch.id = c.get<uint16_t>();
    ch.schema_id = c.get<uint16_t>();
    ch.topic = c.str();
    ch.message_encoding = c.str();
    ch.metadata = c.str_map();
    if (ch.schema_id != 0 && info.schemas.count(ch.schema_id) == 0) {
      throw McapError(where + ": channel '" + ch.topic + "' names schema " + std::to_string(ch.schema_id) +
                      ", which no Schema record defined before it");
    }
    const auto it = info.channels.find(ch.id);
    if (it != info.channels.end() && it->second.topic != ch.topic) {
      throw McapError(where + ": channel " + std::to_string(ch.id) + " is defined twice, differently");
    }
    if (it == info.channels.end()) info.channels[ch.id] = std::move(ch);  // keep the address messages point to
  };

  try {
    while (!footer) {
      if (pos == m.n) {
        throw McapError(where + ": the file ends at byte " + std::to_string(m.n) + " before its " +
                        (data_end ? "footer" : "DataEnd record, summary and footer") +
                        " (cut short: was the recorder killed, or the copy incomplete?)");
      }
      if (m.n - pos < 9) {
        throw McapError(where + ": truncated: " + std::to_string(m.n - pos) + " byte(s) at byte " + std::to_string(pos) +
                        " where a record (9-byte opcode and length) should begin");
      }
      const auto op = static_cast<uint8_t>(m.p[pos]);
      uint64_t len = 0;
      for (int i = 0; i < 8; ++i) len |= static_cast<uint64_t>(static_cast<unsigned char>(m.p[pos + 1 + i])) << (8 * i);
      const std::string rec_name = std::string(op_name(op)) + " record (opcode 0x" +
                                   "0123456789abcdef"[op >> 4] + "0123456789abcdef"[op & 15] + ") at byte " + std::to_string(pos);
      if (len > m.n - pos - 9) {
        throw McapError(where + ": truncated: the " + rec_name + " declares " + std::to_string(len) +
                        " bytes, but the file ends " + std::to_string(m.n - pos - 9) + " bytes after its header");
      }
      if (!header && op != kHeader) throw McapError(where + ": the first record is a " + rec_name + ", not a Header");
      Cursor c(m.p + pos + 9, len, pos + 9, where + ": " + rec_name);
      switch (op) {
        case kHeader:
          if (header) throw McapError(where + ": a second Header record at byte " + std::to_string(pos));
          header = true;
          info.profile = c.str();
          info.library = c.str();
          break;
        case kSchema:
          schema(c, data_end);
          break;
        case kChannel:
          channel(c);
          break;
        case kMessage:
          if (data_end) throw McapError(where + ": a message in the summary section, at byte " + std::to_string(pos));
          message(c, pos);
          break;
        case kChunk: {
          if (data_end) throw McapError(where + ": a chunk in the summary section, at byte " + std::to_string(pos));
          c.get<uint64_t>();
          c.get<uint64_t>();
          const uint64_t usize = c.get<uint64_t>();
          const uint32_t ucrc = c.get<uint32_t>();
          const std::string compression = c.str();
          const uint64_t rlen = c.get<uint64_t>();
          const char* recs = c.take(rlen);
          if (!compression.empty()) {
            throw McapError(where + ": " + rec_name + " is compressed with '" + compression +
                            "'; this reader reads uncompressed chunks only (as tandem record writes them)");
          }
          if (rlen != usize) {
            throw McapError(where + ": " + rec_name + " holds " + std::to_string(rlen) + " bytes but says " +
                            std::to_string(usize) + " uncompressed");
          }
          if (ucrc != 0 && crc32(recs, rlen) != ucrc) {
            throw McapError(where + ": " + rec_name + " is corrupt: the CRC of its records does not match");
          }
          // Parse the chunk fully before delivering (a damaged chunk delivers nothing).
          struct Pending { uint64_t at; const char* p; uint64_t n; };
          std::vector<Pending> msgs;
          uint64_t q = 0;
          while (q < rlen) {
            if (rlen - q < 9) throw McapError(where + ": " + rec_name + ": a record inside is cut short");
            const auto iop = static_cast<uint8_t>(recs[q]);
            uint64_t ilen = 0;
            for (int i = 0; i < 8; ++i) ilen |= static_cast<uint64_t>(static_cast<unsigned char>(recs[q + 1 + i])) << (8 * i);
            if (ilen > rlen - q - 9) throw McapError(where + ": " + rec_name + ": a record inside runs past the chunk");
            const auto at = static_cast<uint64_t>(recs - m.p) + q;  // the inner record's offset in the file
            Cursor ic(recs + q + 9, ilen, at + 9, where + ": " + rec_name);
            if (iop == kSchema) {
              schema(ic, false);
            } else if (iop == kChannel) {
              channel(ic);
            } else if (iop == kMessage) {
              msgs.push_back({at, recs + q + 9, ilen});
            } else {
              throw McapError(where + ": " + rec_name + " holds a " + op_name(iop) + " record, which a chunk may not");
            }
            q += 9 + ilen;
          }
          for (const auto& pm : msgs) {
            Cursor mc(pm.p, pm.n, pm.at + 9, where + ": message");
            message(mc, pm.at);
          }
          ++info.chunks;
          break;
        }
        case kMetadata: {
          McapMetadata md;
          md.name = c.str();
          md.values = c.str_map();
          info.metadata.push_back(std::move(md));
          break;
        }
        case kDataEnd: {
          const uint32_t crc = c.get<uint32_t>();
          if (crc != 0 && crc32(m.p, pos) != crc) {
            throw McapError(where + ": the data section is corrupt: its CRC (DataEnd record at byte " + std::to_string(pos) +
                            ") does not match");
          }
          data_end = true;
          break;
        }
        case kStatistics:
          summary_messages = c.get<uint64_t>();
          have_stats = true;
          break;
        case kChunkIndex:
          ++chunk_indexes;
          break;
        case kFooter: {
          const uint64_t summary_start = c.get<uint64_t>();
          c.get<uint64_t>();
          const uint32_t crc = c.get<uint32_t>();
          if (summary_start != 0 && crc != 0) {
            if (summary_start > pos) throw McapError(where + ": the footer's summary start is past the footer");
            const uint32_t got = crc32(m.p + pos, 1 + 8 + 16, crc32(m.p + summary_start, pos - summary_start));
            if (got != crc) throw McapError(where + ": the summary section is corrupt: its CRC (footer) does not match");
          }
          footer = true;
          info.summary = summary_start != 0;
          break;
        }
        default:
          break;  // MessageIndex, MetadataIndex, SummaryOffset, attachments, unknown opcodes: skipped (the spec lets readers)
      }
      pos += 9 + len;
    }
    if (m.n - pos != 8 || std::memcmp(m.p + pos, kMagic, 8) != 0) {
      throw McapError(where + ": no closing magic after the footer (byte " + std::to_string(pos) + ")");
    }
    if (have_stats && summary_messages != info.messages) {
      throw McapError(where + ": the summary counts " + std::to_string(summary_messages) + " messages, the file holds " +
                      std::to_string(info.messages));
    }
    if (info.summary && chunk_indexes != info.chunks) {
      throw McapError(where + ": the summary indexes " + std::to_string(chunk_indexes) + " chunks, the file holds " +
                      std::to_string(info.chunks));
    }
  } catch (const McapError& e) {
    if (!salvage) throw;
    info.salvaged = true;
    info.damage = e.what();
  }
  return info;
}

}  // namespace tandem::record
