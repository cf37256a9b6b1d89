// Drives an exported tour (`exploremaps export`) in headless Chromium for tests/tour.rs.
// usage: node tour.mjs URL OUT_DIR VIEWER...   (PLAYWRIGHT_CORE: playwright-core's index.mjs)
// For each viewer: open URL/VIEWER/index.html, wait for the first view, turn to
// each of VIEWS in radians (ExploreMaps' convention), screenshot
// OUT_DIR/VIEWER-0-K.png; with FOLLOW=1 follow the link to TO (default: the first link), wait for the
// transition to end, screenshot OUT_DIR/VIEWER-1.png (with UNDER_WAY=1 also
// OUT_DIR/VIEWER-under-way.png once the transition shows).
// BENCH=1 (scripts/bench-tour.sh): each viewer in a 1280×720 page, cold, at its first view
// and then zoomed to FOV (radians): the bytes fetched and the time until the last tile the
// view needs has arrived ("sharp"); THROTTLE=1 limits the network to 10 Mbit/s (20 ms latency).
// Prints one JSON object per line: {"step": ..., ...}.
const { chromium } = await import(process.env.PLAYWRIGHT_CORE);
const [url, out, ...viewers] = process.argv.slice(2);
// VIEWS: "yaw,pitch,fov;..." to look at in turn at the first probe.
const views = (process.env.VIEWS || '0,0,1').split(';').map((v) => v.split(',').map(Number)).map(([yaw, pitch, fov]) => ({ yaw, pitch, fov }));
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--disable-quic', '--no-first-run', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
         '--autoplay-policy=no-user-gesture-required'],
});
const report = (step, extra) => console.log(JSON.stringify({ step, ...extra }));
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
// Waits until no tile request has been in flight for `quiet` ms.
const settle = async (page, pending, quiet = 1500, limit = 30000) => {
  const t0 = Date.now();
  let calm = Date.now();
  while (Date.now() - t0 < limit) {
    if (pending.size > 0) calm = Date.now();
    else if (Date.now() - calm > quiet) return;
    await sleep(100);
  }
};
const bench = async (viewer) => {
  const page = await browser.newPage({ viewport: { width: 1280, height: 720 } });
  page.on('pageerror', (e) => report('pageerror', { viewer, error: e.message }));
  if (process.env.THROTTLE === '1') {
    const cdp = await page.context().newCDPSession(page);
    await cdp.send('Network.enable');
    await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 20, downloadThroughput: 10e6 / 8, uploadThroughput: 10e6 / 8 });
  }
  const pending = new Set();
  let bytes = 0, tiles = 0, last = 0, tileBytes = 0;
  page.on('request', (r) => pending.add(r));
  page.on('requestfinished', async (r) => {
    pending.delete(r);
    last = Date.now();
    const size = (await r.sizes().catch(() => ({ responseBodySize: 0 }))).responseBodySize;
    bytes += size;
    if (r.url().includes('/tiles/')) { tiles += 1; tileBytes += size; }
  });
  page.on('requestfailed', (r) => pending.delete(r));
  const t0 = Date.now();
  await page.goto(`${url}/${viewer}/index.html`);
  await page.waitForFunction(() => window.exploremapsTour && window.exploremapsTour.view() && window.exploremapsTour.view().scene, null, { timeout: 60000 });
  await settle(page, pending, 2000, 120000);
  report('sharp', { viewer, view: 'first', ms: last - t0, bytes, tiles, tile_bytes: tileBytes });
  const fov = Number(process.env.FOV || 0.35);
  const t1 = Date.now();
  const before = { bytes, tiles, tileBytes };
  await page.evaluate((fov) => { const v = window.exploremapsTour.view(); window.exploremapsTour.look(v.yaw, v.pitch, fov); }, fov);
  await settle(page, pending, 2000, 120000);
  report('sharp', { viewer, view: `zoomed to ${fov} rad`, ms: Math.max(0, last - t1), bytes: bytes - before.bytes, tiles: tiles - before.tiles, tile_bytes: tileBytes - before.tileBytes, fov: (await page.evaluate(() => window.exploremapsTour.view())).fov });
  await page.close();
};
try {
  for (const viewer of process.env.BENCH === '1' ? [] : viewers) {
    const page = await browser.newPage({ viewport: { width: Number(process.env.WIDTH || 800), height: Number(process.env.HEIGHT || 600) } });
    page.on('pageerror', (e) => report('pageerror', { viewer, error: e.message }));
    const pending = new Set();
    const tiles = [];
    page.on('request', (r) => { if (r.url().includes('/tiles/')) { pending.add(r); tiles.push(r.url()); } });
    page.on('requestfinished', (r) => pending.delete(r));
    page.on('requestfailed', (r) => { pending.delete(r); report('requestfailed', { viewer, url: r.url() }); });
    const t0 = Date.now();
    await page.goto(`${url}/${viewer}/index.html`);
    await page.waitForFunction(() => window.exploremapsTour && window.exploremapsTour.view() && window.exploremapsTour.view().scene, null, { timeout: 30000 });
    for (const [k, view] of views.entries()) {
      await page.evaluate((v) => window.exploremapsTour.look(v.yaw, v.pitch, v.fov), view);
      await sleep(500);
      await settle(page, pending);
      report('first', { viewer, k, ms: Date.now() - t0, tiles: tiles.length, view: await page.evaluate(() => window.exploremapsTour.view()) });
      await page.screenshot({ path: `${out}/${viewer}-0-${k}.png` });
    }
    if (process.env.FOLLOW === '1') {
      const to = process.env.TO || await page.evaluate(() => window.exploremapsTour.links()[0].to);
      const followed = await page.evaluate((to) => window.exploremapsTour.follow(to), to);
      if (!followed) throw new Error(`${viewer}: no link to ${to}`);
      if (process.env.UNDER_WAY === '1') {
        // A screenshot once the transition's overlay shows.
        await page.waitForFunction(() => {
          const c = document.querySelector('canvas.exploremaps-transition');
          return c && c.style.opacity === '1';
        }, null, { timeout: 30000 });
        await page.screenshot({ path: `${out}/${viewer}-under-way.png` });
      }
      await page.waitForFunction(() => {
        const s = window.exploremapsTour.state;
        return s.transitions.length > 0 && s.transitions[s.transitions.length - 1].done && !s.moving;
      }, null, { timeout: 60000 });
      await sleep(500);
      await settle(page, pending);
      const state = await page.evaluate(() => window.exploremapsTour.state);
      report('followed', { viewer, followed, view: await page.evaluate(() => window.exploremapsTour.view()), transition: state.transitions[state.transitions.length - 1] });
      await page.screenshot({ path: `${out}/${viewer}-1.png` });
    }
    await page.close();
  }
  if (process.env.BENCH === '1') for (const viewer of viewers) await bench(viewer);
} catch (e) {
  report('error', { error: String(e && e.stack || e) });
  process.exitCode = 1;
} finally {
  await browser.close();
}
