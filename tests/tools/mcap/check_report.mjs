// Opens a `tandem report` page in headless Chromium (Debian's, driven by playwright-core) and checks that it
// loads without errors and that its plots are real images of the run; saves a screenshot beside it.
// usage: node check_report.mjs DIR MIN_IMAGES [CHROMIUM]
import { chromium } from "playwright-core";
import { readFile } from "node:fs/promises";
import path from "node:path";

const [dir, minImagesText, exe = "/usr/bin/chromium"] = process.argv.slice(2);
const minImages = Number(minImagesText);
if (!dir || !(minImages > 0)) {
  console.error("usage: node check_report.mjs DIR MIN_IMAGES [CHROMIUM]");
  process.exit(2);
}
const fail = (why) => {
  console.error(`check_report: FAIL: ${why}`);
  process.exit(1);
};

const browser = await chromium.launch({ executablePath: exe, args: ["--no-sandbox", "--disable-gpu"] });
const problems = [];
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 1800 } });
  page.on("console", (m) => { if (m.type() === "error" || m.type() === "warning") problems.push(`console ${m.type()}: ${m.text()}`); });
  page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
  page.on("requestfailed", (r) => problems.push(`request failed: ${r.url()} (${r.failure()?.errorText})`));
  const url = "file://" + path.resolve(dir, "index.html");
  const resp = await page.goto(url, { waitUntil: "load" });
  if (!resp || !resp.ok()) fail(`${url} did not load`);
  const images = await page.$$eval("img", (imgs) =>
    imgs.map((i) => ({ src: i.getAttribute("src"), complete: i.complete, w: i.naturalWidth, h: i.naturalHeight })));
  if (images.length < minImages) fail(`${images.length} images on the page, at least ${minImages} expected`);
  for (const im of images) {
    if (!im.complete || im.w === 0 || im.h === 0) fail(`image ${im.src} did not render (${im.w}x${im.h})`);
  }
  // Each plot holds data (a polyline of 5 points or more), and most of them vary (a lockstep run's late ticks
  // per second are flat at zero, rightly).
  let withData = 0, varying = 0;
  for (const im of images) {
    const svg = await readFile(path.resolve(dir, im.src), "utf8");
    let data = false, moves = false;
    for (const m of svg.matchAll(/<polyline[^>]*points="([^"]+)"/g)) {
      const pts = m[1].trim().split(/\s+/).map((p) => p.split(",").map(Number));
      if (pts.length >= 5) data = true;
      if (pts.length >= 20 && new Set(pts.map((p) => p[1].toFixed(1))).size >= 3) moves = true;
    }
    if (!data) fail(`plot ${im.src} holds no data curve`);
    ++withData;
    if (moves) ++varying;
  }
  if (varying * 2 < images.length) fail(`only ${varying} of ${images.length} plots vary`);
  const curves = `${withData} plots with data, ${varying} varying`;
  const title = await page.title();
  if (!title.startsWith("tandem")) fail(`unexpected page title '${title}'`);
  await page.screenshot({ path: path.resolve(dir, "screenshot.png"), fullPage: false });
  if (problems.length > 0) fail(problems.join("\n"));
  console.log(`check_report: OK: '${title}', ${images.length} images rendered, ${curves}, no console errors; ` +
              `screenshot ${path.resolve(dir, "screenshot.png")}`);
} finally {
  await browser.close();
}
