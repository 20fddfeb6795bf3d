// Independent reader of a tandem recording: @mcap/core's indexed reader (footer, summary, chunk and message
// indexes, CRCs) and protobufjs with the FileDescriptorSet each schema record holds. No tandem code.
// usage: node check_recording.mjs RUN.mcap SUMMARY.txt
// Checks that every tick of every arm is there (sensor samples and the primary robots' torque commands), and
// that the RMS recomputed from the recorded errors equals what the run printed in its summary (tandem up
// --summary), and what the robots published at the end (RobotSummary, recorded too).
import { McapIndexedReader } from "@mcap/core";
import protobuf from "protobufjs";
import "protobufjs/ext/descriptor/index.js";
import { open, readFile } from "node:fs/promises";

const [file, summaryFile] = process.argv.slice(2);
if (!file || !summaryFile) {
  console.error("usage: node check_recording.mjs RUN.mcap SUMMARY.txt");
  process.exit(2);
}
const fail = (why) => {
  console.error(`check_recording: FAIL: ${why}`);
  process.exit(1);
};

const fh = await open(file, "r");
const size = (await fh.stat()).size;
const readable = {
  size: async () => BigInt(size),
  read: async (offset, length) => {
    const buf = new Uint8Array(Number(length));
    await fh.read(buf, 0, Number(length), Number(offset));
    return buf;
  },
};
const reader = await McapIndexedReader.Initialize({ readable });
if (reader.chunkIndexes.length === 0) fail("no chunk index in the summary");

// One protobufjs type per schema, built from the schema's FileDescriptorSet alone.
const types = new Map();
for (const [id, schema] of reader.schemasById) {
  if (schema.encoding !== "protobuf") fail(`schema ${schema.name} has encoding ${schema.encoding}`);
  const root = protobuf.Root.fromDescriptor(schema.data);
  types.set(id, root.lookupType(schema.name));
}

const sensors = new Map();   // arm -> Set(tick)
const commands = new Map();  // robot id -> Map(tick -> {e, phi, eh})
const robotSummaries = new Map();
let messages = 0;
for await (const m of reader.readMessages()) {
  ++messages;
  const ch = reader.channelsById.get(m.channelId);
  const type = types.get(ch.schemaId);
  const msg = type.toObject(type.decode(m.data), { longs: Number, defaults: true });
  if (ch.topic.startsWith("tandem/arm_sensors/")) {
    const arm = ch.topic.slice("tandem/arm_sensors/".length);
    if (!sensors.has(arm)) sensors.set(arm, new Set());
    sensors.get(arm).add(msg.tick);
  } else if (ch.topic.startsWith("tandem/torque_commands/")) {
    const arm = ch.topic.slice("tandem/torque_commands/".length);
    if (msg.leaving) continue;
    const id = msg.strength === 100 ? arm : `${arm}@${msg.strength}`;
    if (!commands.has(id)) commands.set(id, new Map());
    const ep = msg.eP ?? msg.e_p;
    const eh = msg.eH ?? msg.e_h;
    // A repeat of a tick (lockstep asks again) carries the same answer: kept once.
    if (!commands.get(id).has(msg.tick)) commands.get(id).set(msg.tick, { e: Math.hypot(ep[0], ep[1]), phi: ep[2], eh });
  } else if (ch.topic === "tandem/robot_summary") {
    robotSummaries.set(msg.robotId ?? msg.robot_id, msg);
  }
}
await fh.close();
const stats = reader.statistics;
if (stats && Number(stats.messageCount) !== messages) fail(`statistics say ${stats.messageCount} messages, read ${messages}`);

// The run's own summary (tandem up --summary): key=value.
const printed = new Map();
for (const line of (await readFile(summaryFile, "utf8")).split("\n")) {
  const eq = line.indexOf("=");
  if (eq > 0) printed.set(line.slice(0, eq), line.slice(eq + 1));
}
const worldTicks = Number(printed.get("m1.ticks"));
if (!(worldTicks > 0)) fail(`no m1.ticks in ${summaryFile}`);

const rms = (values) => Math.sqrt(values.reduce((s, v) => s + v * v, 0) / values.length);
const close = (a, b) => Math.abs(a - b) <= 1e-9 * Math.max(Math.abs(a), Math.abs(b), 1e-300);
let robots = 0;
for (const [id, ticks] of commands) {
  if (id.includes("@")) continue;  // standbys: not in the printed summary of a run without failover
  ++robots;
  const n = Number(printed.get(`${id}.ticks`));
  if (ticks.size !== n) fail(`${id}: ${ticks.size} ticks recorded, the summary says ${n}`);
  for (let k = 0; k < n; ++k) if (!ticks.has(k)) fail(`${id}: tick ${k} missing from the recording`);
  const v = [...ticks.values()];
  const got = { ep_pos_rms: rms(v.map((x) => x.e)), ep_ori_rms: rms(v.map((x) => x.phi)), eh_rms: rms(v.map((x) => x.eh)) };
  for (const [key, value] of Object.entries(got)) {
    const want = Number(printed.get(`${id}.${key}`));
    if (!close(value, want)) fail(`${id}: ${key} from the recording ${value}, printed ${want}`);
    const rs = robotSummaries.get(id);
    const camel = key.replace(/_([a-z])/g, (_, c) => c.toUpperCase());
    const published = rs ? Number(rs[camel] ?? rs[key]) : NaN;
    if (!close(value, published)) fail(`${id}: ${key} from the recording ${value}, its RobotSummary ${published}`);
  }
  console.log(`${id}: ${ticks.size} ticks, e_p RMS ${got.ep_pos_rms.toExponential(9)} m = printed ${printed.get(`${id}.ep_pos_rms`)}, ` +
              `e_phi RMS ${got.ep_ori_rms.toExponential(6)}, e_h RMS ${got.eh_rms.toFixed(6)} N`);
}
if (robots < 2) fail(`commands of ${robots} primary robot(s) recorded, 2 expected`);
for (const [arm, ticks] of sensors) {
  for (let k = 0; k < worldTicks; ++k) if (!ticks.has(k)) fail(`${arm}: sensor sample of tick ${k} missing`);
  console.log(`${arm}: sensor samples of all ${worldTicks} ticks`);
}
if (sensors.size < 2) fail(`sensor samples of ${sensors.size} arm(s) recorded, 2 expected`);
console.log(`check_recording: OK: ${messages} messages in ${reader.chunkIndexes.length} chunks, ${types.size} schemas decoded from their FileDescriptorSets`);
