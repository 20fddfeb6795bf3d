// The viewer benchmark's clients (bench/view.sh): for S seconds, one client as the page is (the viewer's JSON
// channels: state, plot, events) and one as Foxglove Studio plotting a per-tick channel at full rate (every
// tandem/arm_sensors/* topic). Prints the messages and bytes each received. No tandem code.
// usage: node bench_clients.mjs ws://HOST:PORT SECONDS
import WebSocket from "ws";

const [url, secondsArg] = process.argv.slice(2);
const seconds = Number(secondsArg);
if (!url || !(seconds > 0)) {
  console.error("usage: node bench_clients.mjs ws://HOST:PORT SECONDS");
  process.exit(2);
}
function client(name, wanted) {
  const stats = {name, messages: 0, bytes: 0};
  const ws = new WebSocket(url, ["foxglove.websocket.v1"]);
  ws.on("error", (e) => { console.error(`${name}: ${e.message}`); process.exit(1); });
  ws.on("message", (data, isBinary) => {
    if (!isBinary) {
      const msg = JSON.parse(data.toString());
      if (msg.op !== "advertise") return;
      const subs = msg.channels.filter((c) => wanted(c.topic)).map((c, i) => ({id: i + 1, channelId: c.id}));
      ws.send(JSON.stringify({op: "subscribe", subscriptions: subs}));
      return;
    }
    if (data[0] !== 0x01) return;
    stats.messages++;
    stats.bytes += data.length;
  });
  return {stats, ws};
}
const page = client("page", (t) => t.startsWith("tandem/view/"));
const studio = client("foxglove", (t) => t.startsWith("tandem/arm_sensors/"));
setTimeout(() => {
  for (const c of [page, studio]) {
    console.log(`${c.stats.name} ${c.stats.messages} ${c.stats.bytes}`);
    c.ws.terminate();
  }
  process.exit(0);
}, seconds * 1000);
