// tandem view's page in headless Chromium (playwright-core, Debian's chromium): the process table fills, the plots
// receive new points over time; after this checker prints READY and then reads GO on its standard input (the test
// has tried bad requests meanwhile), it clicks SUBJECT's kill button, accepts the page's confirmation, and waits
// for the viewer's answer in the header and a new event about SUBJECT; the console shows no errors. Takes a
// screenshot. No tandem code.
// usage: node check_view_page.mjs URL SUBJECT SCREENSHOT.png [CHROMIUM]
import { chromium } from "playwright-core";

const [url, subject, shot, exe = "/usr/bin/chromium"] = process.argv.slice(2);
if (!url || !subject || !shot) {
  console.error("usage: node check_view_page.mjs URL SUBJECT SCREENSHOT.png [CHROMIUM]");
  process.exit(2);
}
const fail = async (why, browser) => {
  console.error(`check_view_page: FAIL: ${why}`);
  if (browser) await browser.close();
process.exit(0);
  process.exit(1);
};
const browser = await chromium.launch({ executablePath: exe, args: ["--no-sandbox", "--disable-gpu"] });
const page = await browser.newPage({ viewport: { width: 1280, height: 1000 } });
const problems = [];
page.on("console", (m) => { if (m.type() === "error") problems.push(`console error: ${m.text()}`); });
page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
await page.goto(url);
try {
  await page.waitForFunction(() => document.querySelectorAll("#procs tbody tr").length >= 3, null, { timeout: 20000 });
} catch { await fail("the process table did not fill within 20 s", browser); }
const rows = await page.$$eval("#procs tbody tr", (r) => r.length);
// Live commands: a visible kill button beside the subject (the page's own buttons; the kill itself goes through the API).
const killButton = await page.evaluate((s) => {
  const row = [...document.querySelectorAll("#procs tbody tr")].find((r) => r.cells[0].textContent === s);
  const b = row && [...row.querySelectorAll("button")].find((x) => x.textContent === "kill");
  if (!b) return "none";
  const r = b.getBoundingClientRect(), box = b.closest("section").getBoundingClientRect();
  return r.width > 0 && r.right <= box.right + 1 ? "visible" : "clipped";
}, subject);
if (killButton !== "visible") await fail(`the kill button of ${subject} is ${killButton}`, browser);
try {
  await page.waitForFunction(() => window.tandemView.plots() >= 2, null, { timeout: 20000 });
} catch { await fail("no plot of both arms within 20 s", browser); }
const points = async () => page.evaluate(() => window.tandemView.received.plot);
const p1 = await points();
await page.waitForTimeout(2000);
const p2 = await points();
if (!(p2 > p1)) await fail(`the plots received no new points in 2 s (${p1} then ${p2} batches)`, browser);
if (!(await page.evaluate(() => typeof uPlot !== "undefined"))) await fail("uPlot was not served with the page", browser);
// The events about SUBJECT shown so far (start-up's lifecycle events are among them): a kill must add one.
const about = (s) => [...document.querySelectorAll("#events div")].filter((d) => d.textContent.includes(s)
                                                                           && /failover|lifecycle|brake/.test(d.textContent)).length;
const before = await page.evaluate(`(${about.toString()})(${JSON.stringify(subject)})`);
console.log(`READY: ${rows} processes, plot batches ${p1} -> ${p2}, ${before} event(s) about ${subject}`);
// Wait for the test's go-ahead (a line on stdin), then kill SUBJECT as a user would: its button, then OK.
const go = await new Promise((resolve) => {
  process.stdin.once("data", () => resolve(true));
  process.stdin.once("end", () => resolve(false));
});
process.stdin.destroy();
if (!go) await fail("no GO on stdin (the test ended first)", browser);
let asked = "";
page.once("dialog", async (d) => { asked = d.message(); await d.accept(); });
const clicked = await page.evaluate((s) => {
  const row = [...document.querySelectorAll("#procs tbody tr")].find((r) => r.cells[0].textContent === s);
  const b = row && [...row.querySelectorAll("button")].find((x) => x.textContent === "kill");
  if (b) b.click();
  return Boolean(b);
}, subject);
if (!clicked) await fail(`no kill button of ${subject} to click`, browser);
try {
  await page.waitForFunction(() => document.getElementById("answer").className === "ok", null, { timeout: 15000 });
} catch {
  await fail(`the kill button got no ok answer within 15 s: "${await page.$eval("#answer", (a) => a.textContent)}"`, browser);
}
if (!asked.includes(subject)) await fail(`the kill was not confirmed first (dialog: "${asked}")`, browser);
const answer = await page.$eval("#answer", (a) => a.textContent);
console.log(`clicked kill ${subject}: confirmation "${asked}", answer "${answer}"`);
try {
  await page.waitForFunction(([s, n]) => [...document.querySelectorAll("#events div")].filter((d) => d.textContent.includes(s)
                                           && /failover|lifecycle|brake/.test(d.textContent)).length > n,
                             [subject, before], { timeout: 30000 });
} catch { await fail(`no new event about ${subject} within 30 s of the click (${before} before)`, browser); }
const event = await page.$$eval("#events div", (ds, s) => ds.map((d) => d.textContent).find((t) => t.includes(s)), subject);
await page.screenshot({ path: shot, fullPage: true });
if (problems.length) await fail(problems.join("; "), browser);
console.log(`check_view_page: PASS: ${rows} processes, plots growing, event "${event}", no console errors; ${shot}`);
await browser.close();
process.exit(0);
