// docs/benchmarks-web.md's measurements: for each .cgc given, served by `isogrid serve` on
// 127.0.0.1, the time to the first frame and to the complete picture in headless Chromium with the
// download throttled by the DevTools protocol (50 Mbit/s, 1 Gbit/s), the bytes transferred and the
// bytes before the first frame; then the frame time (GPU timestamps and wall time with the read-back; median of 5) in Chromium
// and Firefox at the given size.
// Usage: node bench/bench.mjs SIZE FILE.cgc...   (e.g. 640x480; the isogrid binary as in the tests)
import { spawn } from 'node:child_process';
import { statSync } from 'node:fs';
import { createInterface } from 'node:readline';
import puppeteer from 'puppeteer-core';
import { isogridBinary } from '../test/fixtures.mjs';

const [size, ...files] = process.argv.slice(2);

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
    const chromium = await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch.chromium });
    for (const mbit of [50, 1000]) {
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
      const s = await page.evaluate(() => window.isogrid.ready.then(() => window.isogrid.stats));
      console.log(JSON.stringify({ file, total, browser: 'chromium', mbit, firstFrameMs: s.firstFrameAt, lastByteMs: s.completeAt, completeMs: s.readyAt, firstFrameBytes: s.firstFrameBytes, transferred, pages: s.pages }));
      await page.close();
    }
    await chromium.close();
    for (const name of ['chromium', 'firefox']) {
      const browser = await puppeteer.launch({ headless: true, protocolTimeout: 600_000, ...launch[name] });
      const page = await browser.newPage();
      await page.goto(`${url}&view=2&size=${size}`);
      await page.evaluate(() => window.isogrid.ready);
      const f = await page.evaluate(() => window.isogrid.frames(5));
      const adapter = await page.evaluate(() => window.isogrid.stats.adapter);
      console.log(JSON.stringify({ file, browser: name, adapter, size, ...f }));
      await browser.close();
    }
  } finally {
    child.kill();
  }
}
