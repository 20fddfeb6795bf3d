// tandem view over a recording (tandem view run.mcap) in headless Chromium: the page is in replay mode, the slider
// spans the recording, the tables and plots are filled at the end, moving the slider back changes what is shown
// (fewer events), and the console shows no errors. No tandem code.
// usage: node check_view_replay.mjs URL SCREENSHOT.png [CHROMIUM]
import { chromium } from "playwright-core";

const [url, shot, exe = "/usr/bin/chromium"] = process.argv.slice(2);
if (!url || !shot) {
  console.error("usage: node check_view_replay.mjs URL SCREENSHOT.png [CHROMIUM]");
  process.exit(2);
}
const browser = await chromium.launch({ executablePath: exe, args: ["--no-sandbox", "--disable-gpu"] });
const fail = async (why) => {
  console.error(`check_view_replay: FAIL: ${why}`);
  await browser.close();
  process.exit(1);
};
const page = await browser.newPage({ viewport: { width: 1280, height: 1000 } });
const problems = [];
page.on("console", (m) => { if (m.type() === "error") problems.push(`console error: ${m.text()}`); });
page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
await page.goto(url);
try {
  await page.waitForFunction(() => !document.getElementById("replay").hidden &&
                                   document.querySelectorAll("#procs tbody tr").length >= 3, null, { timeout: 20000 });
} catch { await fail("no replay slider and process table within 20 s"); }
const end = await page.evaluate(() => ({ events: document.querySelectorAll("#events div").length,
                                        points: window.tandemView.points().reduce((a, b) => a + b, 0),
                                        min: Number(document.getElementById("slider").min),
                                        max: Number(document.getElementById("slider").max) }));
if (!(end.max - end.min > 1)) await fail(`the slider spans ${end.max - end.min} s`);
if (end.events < 1) await fail("no event at the end of the recording");
if (end.points < 10) await fail(`${end.points} plot points at the end of the recording`);
await page.evaluate((t) => {
  const s = document.getElementById("slider");
  s.value = t;
  s.dispatchEvent(new Event("input"));
}, end.min + 0.2);
try {
  await page.waitForFunction((n) => document.querySelectorAll("#events div").length < n, end.events, { timeout: 10000 });
} catch { await fail("moving the slider to the start did not change the events shown"); }
const startPoints = await page.evaluate(() => window.tandemView.points().reduce((a, b) => a + b, 0));
if (!(startPoints < end.points)) await fail(`the plots still show ${startPoints} points at the start (${end.points} at the end)`);
// The screenshot halfway through the run (at the start there is little to see): the plots fill again.
await page.evaluate((t) => {
  const s = document.getElementById("slider");
  s.value = t;
  s.dispatchEvent(new Event("input"));
}, (end.min + end.max) / 2);
try {
  await page.waitForFunction((n) => window.tandemView.points().reduce((a, b) => a + b, 0) > n, startPoints, { timeout: 10000 });
} catch { await fail("moving the slider halfway did not bring plot points back"); }
await page.screenshot({ path: shot, fullPage: true });
if (problems.length) await fail(problems.join("; "));
console.log(`check_view_replay: PASS: ${end.max - end.min} s, ${end.events} events and ${end.points} points at the end, ` +
            `fewer at the start, no console errors; ${shot}`);
await browser.close();
