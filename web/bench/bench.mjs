// docs/benchmarks-web.md's measurements: for each .cgc given, served by `isogrid serve` on
// 127.0.0.1, the time to the first frame and to the complete picture in headless Chromium with the
// download throttled by the DevTools protocol (50 Mbit/s, 1 Gbit/s), the bytes transferred and the
// bytes before the first frame; then the frame time (GPU timestamps and wall time with the read-back; median of 5) in Chromium
// and Firefox at the given size.
// Usage: node bench/bench.mjs SIZE FILE.cgc...   (e.g. 640x480; the isogrid binary as in the tests)
//   CAP_S (default 1200): seconds a throttled load may take to its complete picture; past it the
//   figures so far are printed with completeMs null. FRAMES (default 5): frames timed per browser.
//   BROWSERS (default 'chromium,firefox'): the browsers of the frame-time part; THROTTLED=0 skips
//   the throttled loads. MAX_RSS_GB (default 8): a browser whose processes hold more memory is
//   closed and the figure reported as over the cap (SwiftShader's memory grows with the cells drawn;
//   this machine is shared).
import { execSync, spawn } from 'node:child_process';
import { statSync } from 'node:fs';
import { createInterface } from 'node:readline';
import puppeteer from 'puppeteer-core';
import { isogridBinary } from '../test/fixtures.mjs';

const [size, ...files] = process.argv.slice(2);
const capMs = 1000 * Number(process.env.CAP_S || 1200);
const frames = Number(process.env.FRAMES || 5);
const browsers = (process.env.BROWSERS || 'chromium,firefox').split(',');
const maxRss = Number(process.env.MAX_RSS_GB || 8) * 2 ** 30;

/** Resident bytes of `browser`'s processes (the browser and its descendants). */
function browserRss(browser) {
  const table = execSync('ps -e -o pid=,ppid=,rss=').toString().trim().split('\n').map((l) => l.trim().split(/\s+/).map(Number));
  const ids = new Set([browser.process().pid]);
  for (let grew = true; grew; ) {
    grew = false;
    for (const [pid, ppid] of table) if (ids.has(ppid) && !ids.has(pid)) (ids.add(pid), (grew = true));
  }
  return table.filter(([pid]) => ids.has(pid)).reduce((sum, [, , rss]) => sum + rss * 1024, 0);
}

/** Waits for the complete picture (or an error) for at most `ms`; false when the memory cap is hit. */
async function waitReady(browser, page, ms) {
  const until = Date.now() + ms;
  for (;;) {
    if (browserRss(browser) > maxRss) return false;
    const done = await page.evaluate(() => Boolean(window.isogrid.stats.readyAt || window.isogrid.stats.error));
    if (done || Date.now() > until) return true;
    await new Promise((r) => setTimeout(r, 2000));
  }
}

async function serve(file) {
  const child = spawn(isogridBinary(), ['serve', file, '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
  const line = await new Promise((r) => createInterface({ input: child.stdout }).once('line', r));
  return { child, url: line.split(/\s+/).find((w) => w.startsWith('http://')) };
}

const launch = {
  chromium: { executablePath: '/usr/bin/chromium', browser: 'chrome', args: ['--enable-unsafe-webgpu', '--no-sandbox', '--headless=new'] },
  firefox: { executablePath: '/usr/bin/firefox-esr', browser: 'firefox', extraPrefsFirefox: { 'dom.webgpu.enabled': true, 'gfx.webgpu.ignore-blocklist': true } },
};

for (const file of files) {
  const { child, url } = await serve(file);
  const total = statSync(file).size;
  try {
    const chromium = process.env.THROTTLED === '0' ? null : await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch.chromium });
    for (const mbit of chromium ? [50, 1000] : []) {
      const page = await chromium.newPage();
      let transferred = 0;
      const cdp = await page.createCDPSession();
      await cdp.send('Network.enable');
      await cdp.send('Network.setCacheDisabled', { cacheDisabled: true });
      // Bytes of the .cgc's responses only (not the page and its bundle), headers included.
      const cgc = new Set();
      cdp.on('Network.requestWillBeSent', (e) => /\.cgc$/.test(new URL(e.request.url).pathname) && cgc.add(e.requestId));
      cdp.on('Network.loadingFinished', (e) => cgc.has(e.requestId) && (transferred += e.encodedDataLength));
      await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 1, downloadThroughput: (mbit * 1e6) / 8, uploadThroughput: (mbit * 1e6) / 8 });
      await page.goto(`${url}&view=2&size=${size}`);
      // Polled rather than awaited in one call: a frame on a CPU adapter can take minutes.
      const withinMemory = await waitReady(chromium, page, capMs);
      const s = await page.evaluate(() => window.isogrid.stats);
      if (!withinMemory) {
        // The figures so far (first frame, last byte), then no further load in this browser.
        console.log(JSON.stringify({ file, total, browser: 'chromium', mbit, firstFrameMs: s.firstFrameAt ?? null, lastByteMs: s.completeAt ?? null, firstFrameBytes: s.firstFrameBytes ?? null, transferred, error: `over ${maxRss / 2 ** 30} GiB of memory` }));
        break;
      }
      if (s.error) throw new Error(`${file}: ${s.error}`);
      console.log(JSON.stringify({ file, total, browser: 'chromium', mbit, firstFrameMs: s.firstFrameAt, lastByteMs: s.completeAt, completeMs: s.readyAt ?? null, firstFrameBytes: s.firstFrameBytes, transferred, pages: s.pages, frames: s.frames }));
      await page.close();
    }
    await chromium?.close();
    for (const name of browsers) {
      const browser = await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch[name] });
      try {
        const page = await browser.newPage();
        await page.goto(`${url}&view=2&size=${size}`);
        if (!(await waitReady(browser, page, capMs))) {
          console.log(JSON.stringify({ file, browser: name, size, error: `over ${maxRss / 2 ** 30} GiB of memory` }));
          continue;
        }
        // Unthrottled load on 127.0.0.1 (ms from navigation start), then the frame time.
        const s = await page.evaluate(() => window.isogrid.stats);
        const f = await page.evaluate((n) => window.isogrid.frames(n), frames);
        console.log(JSON.stringify({ file, browser: name, adapter: s.adapter, size, firstFrameMs: s.firstFrameAt, lastByteMs: s.completeAt, completeMs: s.readyAt ?? null, ...f }));
      } finally {
        await browser.close();
      }
    }
  } finally {
    child.kill();
  }
}
