// Drives the web viewer in headless Chromium for tests/viewer.rs.
// usage: node viewer.mjs MODE URL OUT_DIR   (PLAYWRIGHT_CORE: path to playwright-core's index.mjs)
// MODE tour: load, drag, take the path and back, screenshot each step; then a deep link
// to a probe with a corrupt face, and on to the next probe.
// MODE message: load and report the message the page shows.
// MODE xr: with an emulated headset (IWER: iwer's build): Enter VR, 60 XR frames, the head
// turned, a path's target selected with the right controller and travelled, the session
// ended; screenshots window.png, xr.png, xr_turned.png, xr_moving.png, xr_arrived.png, after.png.
// MODE no_xr: whether the Enter VR button shows without WebXR.
// MODE tiles: on a phone-sized page, the tiles of the first view: asked for, in, fetched.
// MODE bench: time to first panorama and frame times in a probe and along a path.
// MODE dollhouse: open in the dollhouse (#dollhouse=1), screenshot it; then click at
// (TAP_X, TAP_Y) and report where the flight lands; then the floor cut (KeyF).
// MODE dollhouse_bench: times to the first and the full dollhouse frames, frame times.
// Prints one JSON object per line: {"step": ..., ...}.
const { chromium } = await import(process.env.PLAYWRIGHT_CORE);
const [mode, url, out] = process.argv.slice(2);
// WEBGPU=1: WebGPU on SwiftShader's Vulkan; otherwise WebGL2 (the viewer picks WebGPU when offered).
const gpu = process.env.WEBGPU === '1'
  ? ['--enable-unsafe-webgpu', '--enable-features=Vulkan', '--use-vulkan=swiftshader', '--use-angle=swiftshader']
  : ['--disable-gpu'];
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--disable-quic', '--no-first-run', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', ...gpu],
});
// The times between the page's next n animation frames.
const frameTimes = (page, n) => page.evaluate((n) => new Promise((done) => {
  const times = []; let last = performance.now();
  const step = (t) => { times.push(t - last); last = t; if (times.length < n) requestAnimationFrame(step); else done(times); };
  requestAnimationFrame(step);
}), n);
const report = (step, extra) => console.log(JSON.stringify({ step, ...extra }));
const status = (page) => page.evaluate(() => ({ ...(window.exploremaps || {}), hash: location.hash,
  message: document.getElementById('message')?.className === 'shown' ? document.getElementById('message').textContent : null }));
const open = async (target, viewport = { width: 1280, height: 720 }) => {
  const page = await browser.newPage({ viewport });
  page.on('pageerror', (e) => report('pageerror', { error: e.message }));
  const t0 = Date.now();
  await page.goto(target);
  await page.waitForFunction(() => window.exploremaps && (window.exploremaps.first_panorama_ms || window.exploremaps.error
    || document.getElementById('message')?.className === 'shown'), null, { timeout: 30000 });
  return { page, ms: Date.now() - t0 };
};
try {
  if (mode === 'tour') {
    const { page } = await open(url);
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/start.png` });
    report('start', await status(page));
    // Drag from right to left: the view turns right (toward +X).
    await page.mouse.move(1100, 300);
    await page.mouse.down();
    await page.mouse.move(158, 300, { steps: 20 });
    await page.mouse.up();
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/turned.png` });
    report('turned', await status(page));
    // Clicks the path bar's only tile, centred above the probe bar, and shows the travel under way.
    const takePath = async (step) => {
      await page.mouse.click(640, 581);
      await page.waitForFunction(() => window.exploremaps.moving === true, null, { timeout: 30000 });
      await page.waitForTimeout(700);
      await page.screenshot({ path: `${out}/${step}.png` });
      report(step, await status(page));
    };
    await takePath('travel');
    await page.waitForFunction(() => window.exploremaps.moving === false && window.exploremaps.probe === 1, null, { timeout: 30000 });
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/arrived.png` });
    report('arrived', await status(page));
    // The same path back: its video plays backwards, seeked frame by frame.
    await takePath('back_travel');
    await page.waitForFunction(() => window.exploremaps.moving === false && window.exploremaps.probe === 0, null, { timeout: 30000 });
    report('back', await status(page));
    await page.close();
    // A probe whose cube has a corrupt face: a message, then the viewer goes on.
    const bad = await open(`${url}#probe=2`);
    await bad.page.waitForFunction(() => document.getElementById('message').className === 'shown', null, { timeout: 15000 });
    report('corrupt', await status(bad.page));
    await bad.page.keyboard.press('KeyN');
    await bad.page.waitForFunction(() => window.exploremaps.probe === 0 && window.exploremaps.moving === false, null, { timeout: 15000 });
    await bad.page.waitForTimeout(300);
    await bad.page.screenshot({ path: `${out}/recovered.png` });
    report('recovered', await status(bad.page));
  } else if (mode === 'glide') {
    // Turns toward +X, takes the path (it has no video: a glide), shows it under way and arrives.
    const { page } = await open(url);
    await page.waitForTimeout(300);
    await page.mouse.move(1100, 300);
    await page.mouse.down();
    await page.mouse.move(158, 300, { steps: 20 });
    await page.mouse.up();
    await page.waitForTimeout(300);
    await page.mouse.click(640, 581);
    await page.waitForFunction(() => window.exploremaps.moving === true, null, { timeout: 30000 });
    await page.waitForTimeout(700);
    await page.screenshot({ path: `${out}/glide.png` });
    report('gliding', await status(page));
    await page.waitForFunction(() => window.exploremaps.moving === false && window.exploremaps.probe === 1, null, { timeout: 30000 });
    report('arrived', await status(page));
    await page.close();
  } else if (mode === 'tiles') {
    // A phone screen (as in 'phone'): how many tiles the first view asks for and gets.
    const context = await browser.newContext({ viewport: { width: 360, height: 740 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
    const page = await context.newPage();
    page.on('pageerror', (e) => report('pageerror', { error: e.message }));
    const fetched = [];
    page.on('request', (r) => { if (r.url().includes('/tiles/')) fetched.push(new URL(r.url()).pathname); });
    await page.goto(url);
    await page.waitForFunction(() => window.exploremaps && window.exploremaps.tiles_requested > 0
      && window.exploremaps.tiles_in === window.exploremaps.tiles_requested, null, { timeout: 30000 });
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/tiles.png` });
    report('tiles', { ...(await status(page)), fetched });
  } else if (mode === 'tiles_bench') {
    // scripts/bench-tour.sh: a 1280x720 page, cold, at the first view and opened
    // zoomed (deep link fov=FOV_DEG): bytes fetched and the time until the last tile
    // the view asked for is in; THROTTLE=1: 10 Mbit/s, 20 ms latency.
    for (const hash of ['', `#probe=0&fov=${process.env.FOV_DEG || 20}`]) {
      const page = await browser.newPage({ viewport: { width: 1280, height: 720 } });
      page.on('pageerror', (e) => report('pageerror', { error: e.message }));
      if (process.env.THROTTLE === '1') {
        const cdp = await page.context().newCDPSession(page);
        await cdp.send('Network.enable');
        await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 20, downloadThroughput: 10e6 / 8, uploadThroughput: 10e6 / 8 });
      }
      let bytes = 0, tileBytes = 0, tiles = 0;
      page.on('requestfinished', async (r) => {
        const size = (await r.sizes().catch(() => ({ responseBodySize: 0 }))).responseBodySize;
        bytes += size;
        if (r.url().includes('/tiles/')) { tiles += 1; tileBytes += size; }
      });
      const t0 = Date.now();
      await page.goto(url + hash);
      await page.waitForFunction(() => window.exploremaps && window.exploremaps.first_panorama_ms, null, { timeout: 60000 });
      await page.waitForFunction(() => window.exploremaps.tiles_requested > 0 && window.exploremaps.tiles_in === window.exploremaps.tiles_requested, null, { timeout: 120000, polling: 10 });
      const ms = Date.now() - t0;
      await page.waitForTimeout(1000);
      report('sharp', { view: hash ? `zoomed (${hash})` : 'first', ms, bytes, tiles, tile_bytes: tileBytes, ...(await status(page)) });
      await page.close();
    }
  } else if (mode === 'phone') {
    // A 360x740 portrait phone screen at 2 device pixels a CSS pixel, touch only.
    const context = await browser.newContext({ viewport: { width: 360, height: 740 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
    const page = await context.newPage();
    page.on('pageerror', (e) => report('pageerror', { error: e.message }));
    await page.goto(url);
    await page.waitForFunction(() => window.exploremaps && window.exploremaps.first_panorama_ms, null, { timeout: 30000 });
    await page.screenshot({ path: `${out}/phone.png` });
    report('phone', await status(page));
    const cdp = await context.newCDPSession(page);
    const touch = (type, points) => cdp.send('Input.dispatchTouchEvent', { type, touchPoints: points.map(([x, y], id) => ({ x, y, id })) });
    // One finger from right to left: the view turns right.
    await touch('touchStart', [[300, 300]]);
    for (let i = 1; i <= 12; i++) await touch('touchMove', [[300 - 20 * i, 300]]);
    await touch('touchEnd', []);
    await page.waitForTimeout(200);
    report('swiped', await status(page));
    // Two fingers spreading apart: zoom in.
    await touch('touchStart', [[150, 300], [210, 300]]);
    for (let i = 1; i <= 10; i++) await touch('touchMove', [[150 - 5 * i, 300], [210 + 5 * i, 300]]);
    await touch('touchEnd', []);
    await page.waitForTimeout(200);
    report('pinched', await status(page));
    // A tap on the path bar's tile (centred above the probe bar).
    await page.touchscreen.tap(180, 660);
    await page.waitForFunction(() => window.exploremaps.moving === false && window.exploremaps.probe === 1, null, { timeout: 30000 });
    report('tapped', await status(page));
    if (process.env.DOLLHOUSE_TAP) {
      // The dollhouse button (the third, top left), then a tap on the proxy.
      await page.touchscreen.tap(98, 22);
      await page.waitForFunction(() => window.exploremaps.dollhouse === true && window.exploremaps.flying === false, null, { timeout: 15000 });
      await page.waitForTimeout(300);
      await page.screenshot({ path: `${out}/phone_dollhouse.png` });
      report('phone_dollhouse', await status(page));
      const [x, y] = process.env.DOLLHOUSE_TAP.split(',').map(Number);
      await page.touchscreen.tap(x, y);
      await page.waitForFunction(() => window.exploremaps.dollhouse === false && window.exploremaps.flying === false, null, { timeout: 15000 });
      await page.waitForTimeout(300);
      report('phone_landed', await status(page));
    }
  } else if (mode === 'dollhouse' || mode === 'dollhouse_bench') {
    const t0 = Date.now();
    const page = await browser.newPage({ viewport: { width: 1280, height: 720 } });
    page.on('pageerror', (e) => report('pageerror', { error: e.message }));
    if (process.env.THROTTLE === '1') {
      // 10 Mbit/s down and up, 60 ms latency, cache off.
      const cdp = await page.context().newCDPSession(page);
      await cdp.send('Network.enable');
      await cdp.send('Network.setCacheDisabled', { cacheDisabled: true });
      await cdp.send('Network.emulateNetworkConditions', { offline: false, latency: 60, downloadThroughput: 10e6 / 8, uploadThroughput: 10e6 / 8 });
    }
    await page.goto(`${url}#dollhouse=1`);
    await page.waitForFunction(() => window.exploremaps && (window.exploremaps.t_dollhouse_full || window.exploremaps.error), null, { timeout: 60000 });
    const loaded_ms = Date.now() - t0;
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/dollhouse.png` });
    const s = await status(page);
    report('dollhouse', { ...s, loaded_ms });
    if (mode === 'dollhouse_bench') {
      await page.keyboard.down('ArrowRight');
      report('orbit', { frames_ms: await frameTimes(page, 60) });
      await page.keyboard.up('ArrowRight');
      report('memory', { js_heap_bytes: await page.evaluate(() => performance.memory ? performance.memory.usedJSHeapSize : null) });
    } else {
      await page.mouse.click(Number(process.env.TAP_X || 640), Number(process.env.TAP_Y || 360));
      await page.waitForFunction(() => window.exploremaps.dollhouse === false && window.exploremaps.flying === false, null, { timeout: 15000 });
      await page.waitForTimeout(600);
      await page.screenshot({ path: `${out}/landed.png` });
      report('landed', await status(page));
      await page.keyboard.press('KeyO');
      await page.waitForFunction(() => window.exploremaps.dollhouse === true && window.exploremaps.flying === false, null, { timeout: 15000 });
      await page.keyboard.press('KeyF');
      await page.waitForTimeout(300);
      await page.screenshot({ path: `${out}/floor.png` });
      report('floor', await status(page));
    }
  } else if (mode === 'panorama_tap') {
    // A click at the centre of the first panorama, once its depth map is in (a fixed
    // wait was too short on a slow machine).
    const { page } = await open(url);
    await page.waitForFunction(() => window.exploremaps.point_to_go === true, null, { timeout: 30000 });
    await page.mouse.click(640, 360);
    await page.waitForFunction(() => window.exploremaps.moving === true, null, { timeout: 30000 });
    await page.waitForFunction(() => window.exploremaps.moving === false, null, { timeout: 30000 });
    await page.waitForTimeout(300);
    report('arrived', await status(page));
  } else if (mode === 'dollhouse_broken') {
    // Opens in the dollhouse with a corrupt proxy: a message, and the panorama shows.
    const page = await browser.newPage({ viewport: { width: 1280, height: 720 } });
    page.on('pageerror', (e) => report('pageerror', { error: e.message }));
    await page.goto(`${url}#dollhouse=1`);
    await page.waitForFunction(() => document.getElementById('message')?.className === 'shown'
      && window.exploremaps.first_panorama_ms, null, { timeout: 30000 });
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/broken.png` });
    report('broken', await status(page));
  } else if (mode === 'no_xr') {
    // A browser whose WebXR offers no headset (Chromium here), and one without WebXR at all
    // (as Safari on iOS): no button, no message.
    const { page } = await open(url);
    report('no_xr', { button: await page.isVisible('#enter-vr'), ...(await status(page)) });
    const context = await browser.newContext({ viewport: { width: 1280, height: 720 } });
    await context.addInitScript(() => { delete Navigator.prototype.xr; });
    const bare = await context.newPage();
    bare.on('pageerror', (e) => report('pageerror', { error: e.message }));
    await bare.goto(url);
    await bare.waitForFunction(() => window.exploremaps && (window.exploremaps.first_panorama_ms || window.exploremaps.error), null, { timeout: 30000 });
    report('no_webxr', { button: await bare.isVisible('#enter-vr'), has_xr: await bare.evaluate(() => 'xr' in navigator), ...(await status(bare)) });
  } else if (mode === 'xr') {
    // An emulated Meta Quest 3 (IWER: iwer's build, injected before the page).
    const context = await browser.newContext({ viewport: { width: 1280, height: 720 } });
    await context.addInitScript({ path: process.env.IWER });
    await context.addInitScript(() => {
      window.xrDevice = new IWER.XRDevice(IWER.metaQuest3, { visibilityMaskEnabled: false, stereoEnabled: true });
      window.xrDevice.installRuntime({ forceInstall: true });
    });
    const page = await context.newPage();
    page.on('pageerror', (e) => report('pageerror', { error: e.message }));
    await page.goto(url);
    await page.waitForFunction(() => window.exploremaps && window.exploremaps.first_panorama_ms, null, { timeout: 30000 });
    await page.waitForSelector('#enter-vr', { state: 'visible', timeout: 10000 });
    await page.waitForTimeout(300);
    await page.screenshot({ path: `${out}/window.png` });
    report('window', await status(page));
    await page.click('#enter-vr');
    const frames = async (n) => {
      const start = await page.evaluate(() => window.exploremaps.xr_frames || 0);
      await page.waitForFunction((k) => (window.exploremaps.xr_frames || 0) >= k, start + n, { timeout: 60000 });
    };
    await frames(60);
    await page.screenshot({ path: `${out}/xr.png` });
    report('xr', await status(page));
    // The head turns 90° to the right (about +Y, negative angle), level.
    await page.evaluate(() => { const a = -Math.PI / 4; window.xrDevice.quaternion.set(0, Math.sin(a), 0, Math.cos(a)); });
    await frames(10);
    await page.screenshot({ path: `${out}/xr_turned.png` });
    report('turned_head', await status(page));
    // The right controller points at the first path's target and pulls its trigger.
    const here = await page.evaluate(() => window.exploremaps.probe);
    const [goal, yaw, pitch] = await page.evaluate(() => window.exploremaps.xr_targets.find((t) => t[0].startsWith('path')));
    const graph = await (await fetch(new URL('graph.json', url))).json();
    const path = graph.paths[Number(goal.split(' ')[1])];
    const expected = path.from === here ? path.to : path.from;
    await page.evaluate(([yaw, pitch]) => {
      const [y, p] = [-yaw * Math.PI / 360, pitch * Math.PI / 360];
      // The rotation turning −Z to (yaw, pitch), the horizon level: about Y by −yaw, then about X by pitch.
      window.xrDevice.controllers.right.quaternion.set(Math.cos(y) * Math.sin(p), Math.sin(y) * Math.cos(p), -Math.sin(y) * Math.sin(p), Math.cos(y) * Math.cos(p));
    }, [yaw, pitch]);
    await frames(5);
    await page.evaluate(() => window.xrDevice.controllers.right.updateButtonValue('trigger', 1));
    await frames(5);
    await page.evaluate(() => window.xrDevice.controllers.right.updateButtonValue('trigger', 0));
    await page.waitForFunction(() => window.exploremaps.moving === true, null, { timeout: 10000 });
    await page.waitForTimeout(600);
    await page.screenshot({ path: `${out}/xr_moving.png` });
    report('selected', { ...(await status(page)), goal, expected });
    await page.waitForFunction((p) => window.exploremaps.moving === false && window.exploremaps.probe === p, expected, { timeout: 60000 });
    await page.screenshot({ path: `${out}/xr_arrived.png` });
    report('arrived', { ...(await status(page)), expected });
    await page.evaluate(() => window.xrDevice.activeSession.end());
    await page.waitForFunction(() => window.exploremaps.xr === false, null, { timeout: 10000 });
    await page.waitForTimeout(500);
    await page.screenshot({ path: `${out}/after.png` });
    report('after', { ...(await status(page)), canvas: await page.evaluate(() => {
      const c = document.getElementById('view'); return [c.width, c.height, c.clientWidth, c.clientHeight]; }) });
  } else if (mode === 'message') {
    const { page } = await open(url);
    report('message', await status(page));
  } else if (mode === 'bench') {
    let { page, ms } = await open(url);
    const s = await status(page);
    report('first', { first_panorama_ms: s.first_panorama_ms, page_ms: ms, backend: s.backend, wasm_ready_ms: s.t_wasm_ready, graph_ms: s.t_graph, device_ms: s.t_device, faces_ms: s.t_faces, app_ms: s.t_app });
    const heap = () => page.evaluate(() => performance.memory ? performance.memory.usedJSHeapSize : null);
    await page.keyboard.down('ArrowRight');
    report('probe', { frames_ms: await frameTimes(page, 60) });
    await page.keyboard.up('ArrowRight');
    // Frame times along a path, and how many distinct video frames reach the screen a second.
    const travel = async (step) => {
      // From the key's event to the first frame drawn as a glide (null: none within 10 s),
      // watched from before the key is pressed.
      await page.evaluate(() => {
        const g = window.exploremapsGlide = { before: window.exploremaps.glide_frames || 0, pressed: null, ms: null };
        addEventListener('keydown', (e) => { if (g.pressed === null) g.pressed = e.timeStamp; }, { capture: true, once: true });
        const t0 = performance.now();
        const poll = () => {
          if (g.pressed !== null && (window.exploremaps.glide_frames || 0) > g.before) g.ms = performance.now() - g.pressed;
          else if (performance.now() - t0 < 15000) requestAnimationFrame(poll);
        };
        requestAnimationFrame(poll);
      });
      await page.keyboard.press('Enter');
      await page.waitForFunction(() => window.exploremaps.moving === true, null, { timeout: 30000 });
      const before = (await status(page)).video_frames || 0;
      const t0 = Date.now();
      const frames_ms = await frameTimes(page, 30);
      const shown = ((await status(page)).video_frames || 0) - before;
      report(step, { frames_ms, video_frames_per_s: shown / ((Date.now() - t0) / 1000), first_glide_ms: await page.evaluate(() => window.exploremapsGlide.ms), glide_frames: (await status(page)).glide_frames });
    };
    await travel('transition');
    const metrics = await (await page.context().newCDPSession(page)).send('Performance.getMetrics').catch(() => ({ metrics: [] }));
    report('memory', { js_heap_bytes: await heap(), metrics: Object.fromEntries((metrics.metrics || []).map((m) => [m.name, m.value])) });
    await page.close();
    // Backwards: path 0 from its far end, facing along it, so Enter takes it.
    const graph = await (await fetch(new URL('graph.json', url))).json();
    const p = graph.paths[0];
    const [a, b] = [p.polyline[p.polyline.length - 1], p.polyline[p.polyline.length - 2]];
    const yaw = Math.atan2(b[0] - a[0], -(b[2] - a[2])) * 180 / Math.PI;
    const back = await open(`${url}#probe=${p.to}&yaw=${yaw.toFixed(1)}`);
    page = back.page;
    await page.waitForTimeout(500);
    await travel('backward');
  }
} catch (e) {
  report('error', { error: String(e) });
} finally {
  await browser.close();
}
