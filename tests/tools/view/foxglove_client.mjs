// An independent Foxglove WebSocket protocol client (foxglove/ws-protocol spec; no tandem code): it connects to
// tandem view, reads serverInfo and advertise, subscribes to one per-tick protobuf channel, decodes each message
// with protobufjs from the advertised FileDescriptorSet alone, and checks that the ticks come consecutively.
// usage: node foxglove_client.mjs ws://HOST:PORT TOPIC N [--stall SECONDS | --drops]
//   --stall S: subscribe to every channel, then read nothing for S seconds (a client that never reads), then close.
//   --drops: TOPIC is the page's JSON state channel (tandem/view/state): pass when, within N messages, it counts
//            frames dropped for some topic (the server's bounded queues did drop for a stalled client).
import WebSocket from "ws";
import protobuf from "protobufjs";
import "protobufjs/ext/descriptor/index.js";

const [url, topic, wantArg, flag, stallArg] = process.argv.slice(2);
if (!url || !topic || !wantArg) {
  console.error("usage: node foxglove_client.mjs ws://HOST:PORT TOPIC N [--stall SECONDS]");
  process.exit(2);
}
const want = Number(wantArg);
const stall = flag === "--stall" ? Number(stallArg) : 0;
const drops = flag === "--drops";
const fail = (why) => {
  console.error(`foxglove_client: FAIL: ${why}`);
  process.exit(1);
};
setTimeout(() => fail(`timed out (${got.length} of ${want} messages of ${topic})`), 60000 + stall * 1000).unref();

const ws = new WebSocket(url, ["foxglove.websocket.v1"]);
let info = null, type = null, subId = 1;
const got = [];
ws.on("open", () => {
  if (ws.protocol !== "foxglove.websocket.v1") fail(`server chose subprotocol '${ws.protocol}'`);
});
ws.on("error", (e) => fail(`websocket error: ${e.message}`));
ws.on("message", (data, isBinary) => {
  if (!isBinary) {
    const msg = JSON.parse(data.toString());
    if (msg.op === "serverInfo") {
      info = msg;
      if (!msg.sessionId) fail("serverInfo without sessionId");
    } else if (msg.op === "advertise") {
      if (!info) fail("advertise before serverInfo");
      const ch = msg.channels.find((c) => c.topic === topic);
      if (!ch) fail(`no channel ${topic} among ${msg.channels.length}`);
      if (drops) {
        if (ch.encoding !== "json") fail(`channel ${topic} is ${ch.encoding}, not json`);
        subId = 7;
        ws.send(JSON.stringify({op: "subscribe", subscriptions: [{id: subId, channelId: ch.id}]}));
        return;
      }
      if (ch.encoding !== "protobuf" || ch.schemaEncoding !== "protobuf") fail(`channel ${topic} is ${ch.encoding}`);
      const root = protobuf.Root.fromDescriptor(Buffer.from(ch.schema, "base64"));
      type = root.lookupType(ch.schemaName);
      if (stall > 0) {
        ws.send(JSON.stringify({op: "subscribe", subscriptions: msg.channels.map((c, i) => ({id: i + 1, channelId: c.id}))}));
        ws._socket.pause();  // read nothing: the server's queue for this client must stay bounded
        setTimeout(() => {
          console.log(`foxglove_client: stalled ${stall} s with every channel subscribed; closing`);
          ws._socket.resume();
          ws.terminate();
          process.exit(0);
        }, stall * 1000);
        return;
      }
      subId = 7;
      ws.send(JSON.stringify({op: "subscribe", subscriptions: [{id: subId, channelId: ch.id}]}));
    }
    return;
  }
  const buf = Buffer.from(data);
  if (buf[0] === 0x02) return;  // time
  if (buf[0] !== 0x01) fail(`unknown binary op ${buf[0]}`);
  if (buf.readUInt32LE(1) !== subId) fail(`message for subscription ${buf.readUInt32LE(1)}, not ${subId}`);
  if (drops) {
    const state = JSON.parse(buf.subarray(13).toString());
    const counted = Object.entries(state.drops || {}).filter(([, n]) => n > 0);
    got.push(state);
    if (counted.length > 0) {
      const total = counted.reduce((a, [, n]) => a + n, 0);
      console.log(`foxglove_client: PASS: ${total} frames dropped on ${counted.length} channel(s), e.g. ${counted[0][0]}: ${counted[0][1]}`);
      ws.close();
      process.exit(0);
    }
    if (got.length === want) fail(`no drop counted in ${want} state messages: ${JSON.stringify(state.drops)}`);
    return;
  }
  const m = type.toObject(type.decode(buf.subarray(13)), {longs: Number, defaults: true});
  got.push(m);
  if (got.length === want) {
    // Consecutive ticks of one robot (the one with the most messages: the primary, or the standby that serves).
    const byStrength = new Map();
    for (const x of got) {
      const k = x.strength ?? 0;
      if (!byStrength.has(k)) byStrength.set(k, []);
      byStrength.get(k).push(x.tick);
    }
    const ticks = [...byStrength.values()].sort((a, b) => b.length - a.length)[0];
    let gaps = 0;
    for (let i = 1; i < ticks.length; ++i) if (ticks[i] !== ticks[i - 1] + 1) ++gaps;
    if (gaps > 0) fail(`${gaps} gap(s) in ${ticks.length} ticks of ${topic}: ${ticks.slice(0, 20).join(",")}...`);
    console.log(`foxglove_client: PASS: ${want} messages of ${topic} (${type.fullName}), ticks ${ticks[0]}..${ticks[ticks.length - 1]} consecutive; server '${info.name}'`);
    ws.close();
    process.exit(0);
  }
});
