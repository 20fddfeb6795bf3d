// The MCAP container (own writer and reader) and the Protobuf schema records: round trip, the index a
// seeking reader needs, and the errors a corrupt or truncated file gets.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <tandem_record.pb.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tandem/record/event_deriver.hpp"
#include "tandem/record/mcap.hpp"
#include "tandem/record/recording.hpp"

using namespace tandem::record;

namespace {
std::string temp_path(const char* name) { return "/tmp/tandem-test-" + std::to_string(::getpid()) + "-" + name; }
std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}
void spit(const std::string& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }

// Writes 3 channels x 1000 messages in small chunks; returns the commands written on channel "cmd".
std::vector<tandem::record::TorqueCommand> write_sample(const std::string& path) {
  RecordingWriter w(path, McapWriter::Options{4096, "", "tandem-test"});
  w.metadata("run", {{"deployment", "test"}, {"period", "0.001"}});
  const uint16_t cmd = w.channel("tandem/torque_commands/m1/left", tandem::record::TorqueCommand::descriptor());
  const uint16_t sen = w.channel("tandem/arm_sensors/m1/left", tandem::record::ArmSensors::descriptor());
  const uint16_t ev = w.channel("tandem/events", tandem::record::Event::descriptor());
  std::vector<tandem::record::TorqueCommand> out;
  for (int k = 0; k < 1000; ++k) {
    tandem::record::TorqueCommand c;
    c.set_tick(static_cast<uint64_t>(k));
    for (int i = 0; i < 3; ++i) c.add_tau(0.5 * k + i);
    for (int i = 0; i < 3; ++i) c.add_e_p(1e-4 * std::sin(0.01 * k + i));
    c.set_e_h(0.1 * k);
    c.set_strength(100);
    w.write(cmd, c, 1000000ULL * static_cast<uint64_t>(k));
    out.push_back(c);
    tandem::record::ArmSensors s;
    s.set_tick(static_cast<uint64_t>(k));
    s.set_t(1e-3 * k);
    w.write(sen, s, 1000000ULL * static_cast<uint64_t>(k) + 10);
    if (k % 100 == 0) {
      tandem::record::Event e;
      e.set_kind("lifecycle");
      e.set_subject("m1/left");
      w.write(ev, e, 1000000ULL * static_cast<uint64_t>(k) + 20);
    }
  }
  w.close();
  return out;
}
}  // namespace

TEST_CASE("crc32 is the ISO-HDLC CRC (the check value of '123456789' is 0xCBF43926)", "[record]") {
  CHECK(crc32("123456789", 9) == 0xCBF43926U);
  // Continued in two parts: the same value.
  CHECK(crc32("6789", 4, crc32("12345", 5)) == 0xCBF43926U);
}

TEST_CASE("an MCAP recording reads back message for message, with its schemas and metadata", "[record]") {
  const std::string p = temp_path("roundtrip.mcap");
  const auto written = write_sample(p);
  std::vector<tandem::record::TorqueCommand> got;
  size_t sensors = 0, events = 0;
  uint64_t last_time = 0;
  bool ordered = true;
  const McapInfo info = read_mcap(p, [&](const McapMessageView& v) {
    if (v.log_time < last_time) ordered = false;
    last_time = v.log_time;
    if (v.channel->topic == "tandem/torque_commands/m1/left") {
      tandem::record::TorqueCommand c;
      REQUIRE(c.ParseFromArray(v.data, static_cast<int>(v.size)));
      got.push_back(c);
    } else if (v.channel->topic == "tandem/arm_sensors/m1/left") {
      ++sensors;
    } else {
      ++events;
    }
  });
  CHECK(info.summary);
  CHECK_FALSE(info.salvaged);
  CHECK(info.library == "tandem-test");
  CHECK(info.messages == 2010);
  CHECK(info.chunks > 10);  // 4 KiB chunks
  CHECK(ordered);
  REQUIRE(got.size() == written.size());
  for (size_t i = 0; i < got.size(); ++i) {
    CHECK(got[i].tick() == written[i].tick());
    CHECK(got[i].e_p(1) == written[i].e_p(1));  // bit for bit
  }
  CHECK(sensors == 1000);
  CHECK(events == 10);
  REQUIRE(info.metadata.size() == 1);
  CHECK(info.metadata[0].values.at("period") == "0.001");
  REQUIRE(info.schemas.size() == 3);
  // The schema data is a FileDescriptorSet from which a generic reader builds the type and decodes a message.
  for (const auto& [id, s] : info.schemas) {
    CHECK(s.encoding == "protobuf");
    google::protobuf::FileDescriptorSet set;
    REQUIRE(set.ParseFromString(s.data));
    google::protobuf::DescriptorPool pool;
    for (const auto& f : set.file()) REQUIRE(pool.BuildFile(f) != nullptr);
    CHECK(pool.FindMessageTypeByName(s.name) != nullptr);
  }
  std::remove(p.c_str());
}

TEST_CASE("a corrupt or truncated recording gets an error that says where and what", "[record]") {
  const std::string p = temp_path("damaged.mcap");
  write_sample(p);
  const std::string good = slurp(p);
  auto expect_error = [&](const std::string& bytes, const std::string& needle) {
    spit(p, bytes);
    try {
      read_mcap(p, [](const McapMessageView&) {});
      FAIL("no error for a file that should fail with: " << needle);
    } catch (const McapError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(needle) != std::string::npos);
    }
  };
  SECTION("not MCAP at all") { expect_error("hello, world\n", "not an MCAP file"); }
  SECTION("empty") { expect_error("", "not an MCAP file"); }
  SECTION("cut in the middle of a chunk") { expect_error(good.substr(0, good.size() / 2), "truncated"); }
  SECTION("cut before its footer") { expect_error(good.substr(0, good.size() - 30), "truncated"); }
  SECTION("a flipped byte a third of the way in (a chunk or its index: CRC)") {
    std::string bad = good;
    bad[good.size() / 3] = static_cast<char>(bad[good.size() / 3] ^ 0x40);
    expect_error(bad, "corrupt");
  }
  SECTION("salvage reads every intact chunk before the damage") {
    spit(p, good.substr(0, good.size() / 2));
    size_t n = 0;
    const McapInfo info = read_mcap(p, [&](const McapMessageView&) { ++n; }, true);
    CHECK(info.salvaged);
    CHECK(info.damage.find("truncated") != std::string::npos);
    CHECK(n > 500);
    CHECK(n < 1500);
    CHECK(n == info.messages);
  }
  std::remove(p.c_str());
}

namespace {
uint64_t le(const std::string& b, size_t at, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(b.at(at + static_cast<size_t>(i)))) << (8 * i);
  return v;
}
}  // namespace

TEST_CASE("the summary's chunk and message indexes point at the chunks and messages they name", "[record]") {
  // A seeking reader (Foxglove, @mcap/core's indexed reader) follows these offsets without reading the data
  // section; this test follows them by hand, byte by byte, from the footer.
  const std::string p = temp_path("index.mcap");
  write_sample(p);
  const std::string f = slurp(p);
  const size_t footer = f.size() - 8 - (1 + 8 + 20);
  REQUIRE(static_cast<unsigned char>(f[footer]) == 0x02);
  const uint64_t summary_start = le(f, footer + 9, 8), offsets_start = le(f, footer + 17, 8);
  REQUIRE(summary_start > 0);
  REQUIRE(offsets_start > summary_start);
  // The summary offsets name the chunk-index group.
  uint64_t group = 0, group_len = 0;
  for (size_t at = offsets_start; at < footer;) {
    REQUIRE(static_cast<unsigned char>(f[at]) == 0x0E);
    if (static_cast<unsigned char>(f[at + 9]) == 0x08) {
      group = le(f, at + 10, 8);
      group_len = le(f, at + 18, 8);
    }
    at += 9 + le(f, at + 1, 8);
  }
  REQUIRE(group > 0);
  size_t chunks = 0, messages = 0;
  for (size_t at = group; at < group + group_len; at += 9 + le(f, at + 1, 8)) {
    REQUIRE(static_cast<unsigned char>(f[at]) == 0x08);
    const size_t c = at + 9;
    const uint64_t start_time = le(f, c, 8), end_time = le(f, c + 8, 8), chunk_at = le(f, c + 16, 8),
                   chunk_len = le(f, c + 24, 8);
    // The chunk record is there, as long as said.
    REQUIRE(static_cast<unsigned char>(f[chunk_at]) == 0x06);
    CHECK(9 + le(f, chunk_at + 1, 8) == chunk_len);
    const size_t records = chunk_at + 9 + 8 + 8 + 8 + 4 + 4 + le(f, chunk_at + 9 + 28, 4) + 8;  // after compression ""
    const uint32_t map_len = static_cast<uint32_t>(le(f, c + 32, 4));
    for (size_t m = c + 36; m < c + 36 + map_len; m += 10) {
      const uint64_t channel = le(f, m, 2), index_at = le(f, m + 2, 8);
      // Each message index is a MessageIndex of that channel, whose entries are its messages in the chunk.
      REQUIRE(static_cast<unsigned char>(f[index_at]) == 0x07);
      CHECK(le(f, index_at + 9, 2) == channel);
      const uint32_t n = static_cast<uint32_t>(le(f, index_at + 11, 4));
      for (size_t e = index_at + 15; e < index_at + 15 + n; e += 16) {
        const uint64_t log_time = le(f, e, 8), offset = le(f, e + 8, 8);
        const size_t msg = records + offset;
        REQUIRE(static_cast<unsigned char>(f[msg]) == 0x05);
        CHECK(le(f, msg + 9, 2) == channel);
        CHECK(le(f, msg + 15, 8) == log_time);
        CHECK(log_time >= start_time);
        CHECK(log_time <= end_time);
        ++messages;
      }
    }
    ++chunks;
  }
  CHECK(chunks > 10);
  CHECK(messages == 2010);
  std::remove(p.c_str());
}

namespace {
tandem::record::WorldView world(uint64_t tick, const std::string& left, int left_strength, const std::string& right,
                                int right_strength) {
  tandem::record::WorldView w;
  w.tick = tick;
  auto arm = [](const std::string& name, const std::string& who, int strength) {
    const bool served = strength > 0;
    return tandem::record::ArmOwnerView{name, served, strength, who};
  };
  w.owners = {arm("left", left, left_strength), arm("right", right, right_strength)};
  w.braked = {left_strength == 0, right_strength == 0};
  return w;
}
std::vector<std::string> kinds(const std::vector<tandem::record::DerivedEvent>& events) {
  std::vector<std::string> out;
  out.reserve(events.size());
  for (const auto& e : events) out.push_back(e.kind + " " + e.subject);
  return out;
}
}  // namespace

TEST_CASE("events: failovers and takeovers are derived from owner changes, braked in between is neither", "[record]") {
  tandem::record::EventDeriver d;
  CHECK(d.on_world("m1", world(10, "m1/left", 100, "m1/right", 100)).empty());  // the first report: a baseline
  // The primary dies: its standby serves (weaker): a failover.
  auto e = d.on_world("m1", world(20, "m1/left@50", 50, "m1/right", 100));
  REQUIRE(kinds(e) == std::vector<std::string>{"failover m1/left"});
  CHECK(e[0].module == "m1");
  CHECK(e[0].tick == 20);
  CHECK(e[0].detail == "left=m1/left,right=m1/right -> left=m1/left@50,right=m1/right");
  // The restarted primary takes the arm back (stronger): a takeover.
  CHECK(kinds(d.on_world("m1", world(30, "m1/left", 100, "m1/right", 100))) == std::vector<std::string>{"takeover m1/left"});
  // The same owners again: nothing.
  CHECK(d.on_world("m1", world(40, "m1/left", 100, "m1/right", 100)).empty());
  // Every robot of the right arm dies: braked (a brake, no failover), then a restarted robot releases it (no
  // takeover either: the release tells it).
  CHECK(kinds(d.on_world("m1", world(50, "m1/left", 100, "braked", 0))) == std::vector<std::string>{"brake arm 1"});
  CHECK(kinds(d.on_world("m1", world(60, "m1/left", 100, "m1/right@49", 49))) == std::vector<std::string>{"release arm 1"});
  // Modules are apart: a first report of m2 is its own baseline.
  CHECK(d.on_world("m2", world(5, "m2/left@50", 50, "m2/right", 100)).empty());
}

TEST_CASE("events: a load pause, a dropped object once, lifecycle changes, tasks and commands", "[record]") {
  tandem::record::EventDeriver d;
  auto w = world(10, "m1/left", 100, "m1/right", 100);
  CHECK(d.on_world("m1", w).empty());
  w.load_paused = true;
  w.tick = 20;
  CHECK(kinds(d.on_world("m1", w)) == std::vector<std::string>{"load_pause m1"});
  w.load_paused = false;
  w.failed = true;
  w.failure = "a contact carried no force for 10 ms at tick 25";
  w.braked = {true, true};
  w.owners[0] = {"left", false, 0, "braked"};
  w.owners[1] = {"right", false, 0, "braked"};
  w.tick = 30;
  const auto e = d.on_world("m1", w);
  CHECK(kinds(e) == std::vector<std::string>{"brake arm 0", "brake arm 1", "load_resume m1", "module_failed m1"});
  CHECK(e.back().detail == w.failure);
  w.tick = 40;
  CHECK(d.on_world("m1", w).empty());  // failed stays failed: one event
  // A recorder that joins after the drop still records it.
  tandem::record::EventDeriver late;
  CHECK(kinds(late.on_world("m1", w)) == std::vector<std::string>{"module_failed m1"});

  auto s = d.on_status("m1/left", "m1", 1, "", 0);
  REQUIRE(s.size() == 1);
  CHECK(s[0].detail == "(new) -> inactive");
  CHECK(d.on_status("m1/left", "m1", 1, "", 0).empty());
  s = d.on_status("m1/left", "m1", 4, "cut off from the module's leader", 3200);
  REQUIRE(s.size() == 1);
  CHECK(s[0].detail == "inactive -> error: cut off from the module's leader");
  CHECK(s[0].tick == 3200);

  CHECK(kinds(d.on_assignment(7, "m1", "soak-7")) == std::vector<std::string>{"task_assigned soak-7"});
  CHECK(d.on_assignment(7, "m1", "soak-7").empty());  // re-sent: the same id
  CHECK(kinds(d.on_task_state("m1", 7, 1, 900)) == std::vector<std::string>{"task_done task 7"});
  CHECK(d.on_task_state("m1", 7, 1, 950).empty());
  const auto c = d.on_control("plug", "robot m1/left", "standby");
  REQUIRE(c.size() == 1);
  CHECK(c[0].detail == "plug standby");
}

namespace {
/// The field names of each struct of an IDL file (comments and annotations dropped; arrays and sequences by name).
std::map<std::string, std::set<std::string>> idl_structs(const std::string& path) {
  std::ifstream in(path);
  std::string text, line;
  while (std::getline(in, line)) text += line.substr(0, line.find("//")) + "\n";
  std::map<std::string, std::set<std::string>> out;
  for (size_t at = text.find("struct "); at != std::string::npos; at = text.find("struct ", at + 1)) {
    const size_t open = text.find('{', at), close = text.find("};", at);
    if (open == std::string::npos || close == std::string::npos) break;
    std::istringstream name_in(text.substr(at + 7, open - at - 7));
    std::string name;
    name_in >> name;
    std::istringstream body(text.substr(open + 1, close - open - 1));
    std::string member;
    while (std::getline(body, member, ';')) {
      std::istringstream words(member);
      std::string w, last;
      while (words >> w) last = w;
      if (last.empty()) continue;
      out[name].insert(last.substr(0, last.find('[')));
    }
  }
  return out;
}
}  // namespace

TEST_CASE("recording schema: every field of every recorded IDL struct has its field in tandem_record.proto") {
  // The recording's protobuf messages are written by hand beside the IDL (the recorder converts field by field,
  // record/src/tap.cpp): a field added to the IDL and not to the proto would be lost from every recording without a
  // word (SupervisorPlan.heard_tick, the lockstep lease, was). The structs that are not recorded are listed.
  const std::set<std::string> not_recorded = {"AgentRequest", "AgentChild", "AgentState", "CoordinatorState"};
  const auto idl = idl_structs(std::string(TANDEM_SOURCE_DIR) + "/idl/tandem.idl");
  REQUIRE(idl.size() >= 15);
  (void)tandem::record::SupervisorPlan::descriptor();  // the generated file's descriptors registered
  const auto* pool = google::protobuf::DescriptorPool::generated_pool();
  int compared = 0;
  for (const auto& [name, fields] : idl) {
    if (not_recorded.count(name)) continue;
    INFO("struct " << name);
    const google::protobuf::Descriptor* m = pool->FindMessageTypeByName("tandem.record." + name);
    REQUIRE(m != nullptr);
    for (const std::string& f : fields) {
      INFO("field " << f);
      CHECK(m->FindFieldByName(f) != nullptr);
    }
    ++compared;
  }
  CHECK(compared >= 11);
}
