//! The web viewer (wasm32): a canvas, WebGPU when the browser has it, else
//! WebGL2; images fetched and decoded by the browser (`createImageBitmap`),
//! videos played by a `<video>` element, both copied into textures. The page
//! (web/index.html, written into every bundle) calls `start`.

use crate::app::{App, Gpu, Input, Key, Loaded, Mode, Options, Pano, Platform};
use crate::navigation::Navigator;
use crate::overlay::{OverlayPass, THUMB_H, THUMB_W};
use crate::panorama::{Cube, VideoTexture};
use crate::ui::Link;
use exploremaps_format::{Graph, GRAPH_FILE};
use std::cell::RefCell;
use std::rc::Rc;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;

mod xr;

fn window() -> web_sys::Window {
    web_sys::window().expect("a browser window")
}

fn js_error(e: JsValue) -> String {
    e.as_string().or_else(|| e.dyn_ref::<js_sys::Error>().map(|e| String::from(e.message()))).unwrap_or_else(|| format!("{e:?}"))
}

/// Shows `text` in the page's message box (id "message") for a few seconds.
fn show(text: &str) {
    web_sys::console::warn_1(&text.into());
    let Some(el) = window().document().and_then(|d| d.get_element_by_id("message")) else { return };
    el.set_text_content(Some(text));
    let _ = el.set_attribute("class", "shown");
    let hide = Closure::once_into_js(move || {
        let _ = el.set_attribute("class", "");
    });
    let _ = window().set_timeout_with_callback_and_timeout_and_arguments_0(hide.unchecked_ref(), 6000);
}

async fn fetch(url: &str) -> Result<web_sys::Response, String> {
    let response: web_sys::Response =
        JsFuture::from(window().fetch_with_str(url)).await.map_err(|e| format!("cannot be fetched ({})", js_error(e)))?.unchecked_into();
    if !response.ok() {
        return Err(format!("HTTP {} {}", response.status(), response.status_text()));
    }
    Ok(response)
}

/// Fetches and decodes an image, optionally resized by the browser.
async fn bitmap(url: String, resize: Option<(u32, u32)>) -> Result<web_sys::ImageBitmap, String> {
    let blob: web_sys::Blob = JsFuture::from(fetch(&url).await?.blob().map_err(js_error)?).await.map_err(js_error)?.unchecked_into();
    let promise = match resize {
        Some((w, h)) => {
            let options = web_sys::ImageBitmapOptions::new();
            options.set_resize_width(w);
            options.set_resize_height(h);
            options.set_resize_quality(web_sys::ResizeQuality::High);
            window().create_image_bitmap_with_blob_and_image_bitmap_options(&blob, &options)
        }
        None => window().create_image_bitmap_with_blob(&blob),
    }
    .map_err(js_error)?;
    Ok(JsFuture::from(promise).await.map_err(|e| format!("is not a readable image ({})", js_error(e)))?.unchecked_into())
}

/// Milliseconds since the page's start (0 without a performance clock).
fn page_ms() -> f64 {
    window().performance().map_or(0.0, |p| p.now())
}

/// Fetches a file's bytes: the request leaves at once (so several go out
/// together), the future resolves them.
fn fetch_bytes(url: &str) -> impl std::future::Future<Output = Result<Vec<u8>, String>> {
    let request = window().fetch_with_str(url);
    async move {
        let response: web_sys::Response = JsFuture::from(request).await.map_err(|e| format!("cannot be fetched ({})", js_error(e)))?.unchecked_into();
        if !response.ok() {
            return Err(format!("HTTP {} {}", response.status(), response.status_text()));
        }
        let buffer = JsFuture::from(response.array_buffer().map_err(js_error)?).await.map_err(js_error)?;
        Ok(js_sys::Uint8Array::new(&buffer).to_vec())
    }
}

enum Fetched {
    /// A proxy part's files, to decode.
    ProxyBytes {
        level: usize,
        part: usize,
        file: String,
        bytes: Vec<u8>,
        seen: Option<(String, Vec<u8>)>,
        probes: u32,
    },
    /// A vertex-split stream's coarse level and table, to start refining.
    StreamStart {
        base: String,
        bytes: Vec<u8>,
        seen: Option<(String, Vec<u8>)>,
        probes: u32,
    },
    /// A packet of vertex splits (they arrive in order), and the level the
    /// mesh is at once it is applied.
    Packet {
        level: usize,
        file: String,
        bytes: Vec<u8>,
    },
    DepthMap {
        probe: u32,
        map: exploremaps_format::depthmap::DepthMap,
    },
    DepthCube {
        probe: u32,
        cube: exploremaps_format::depthcube::DepthCube,
    },
    Cube {
        probe: u32,
        size: u32,
        faces: Vec<web_sys::ImageBitmap>,
    },
    Tile {
        probe: u32,
        size: u32,
        slot: usize,
        x: u32,
        y: u32,
        image: web_sys::ImageBitmap,
    },
    Equirect {
        probe: u32,
        image: web_sys::ImageBitmap,
    },
    Thumbnail {
        probe: u32,
        image: web_sys::ImageBitmap,
    },
    Failed {
        what: String,
        error: String,
        probe: Option<u32>,
    },
}

fn copy_image(gpu: &Gpu, source: wgpu::ExternalImageSource, texture: &wgpu::Texture, layer: u32, width: u32, height: u32) {
    gpu.queue.copy_external_image_to_texture(
        &wgpu::CopyExternalImageSourceInfo { source, origin: wgpu::Origin2d::ZERO, flip_y: false },
        wgpu::CopyExternalImageDestInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
            aspect: wgpu::TextureAspect::All,
            color_space: wgpu::PredefinedColorSpace::Srgb,
            premultiplied_alpha: false,
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
}

/// A cube face as fetched: its image, or the failure to report for the cube.
type FaceResult = Result<web_sys::ImageBitmap, Fetched>;

/// The frame callback, which schedules itself again.
type FrameLoop = Rc<RefCell<Option<Closure<dyn FnMut(f64)>>>>;

/// Milliseconds of a frame that decoding proxy parts may take (after the first).
const DECODE_BUDGET_MS: f64 = 4.0;

struct WebPlatform {
    base: String,
    done: Rc<RefCell<Vec<Fetched>>>,
    video: web_sys::HtmlVideoElement,
    video_texture: Option<VideoTexture>,
    playing: Option<bool>,
    message: Option<String>,
    faces_marked: bool,
    /// The video time last copied, and how many distinct ones were (for the benchmark).
    video_time: f64,
    video_frames: u32,
    /// The longest decoding of a proxy part, finest level and coarser ones (ms).
    decode_ms: [f64; 2],
    /// The proxy level being refined by vertex splits, and the level it is
    /// at when this frame's packets have changed it.
    refining: Option<crate::dollhouse::Refining>,
    refined: Option<usize>,
}

impl WebPlatform {
    /// Turns what was fetched into what the app takes in (None: nothing yet).
    fn take(&mut self, f: Fetched, gpu: &Gpu, overlay: &OverlayPass) -> Option<Loaded> {
        Some(match f {
            Fetched::Cube { probe, size, faces } => {
                if !self.faces_marked {
                    self.faces_marked = true;
                    mark("faces");
                }
                let cube = Cube::new(&gpu.device, size);
                for (layer, face) in faces.into_iter().enumerate() {
                    // Not closed here: WebGL copies when the queue is submitted.
                    copy_image(gpu, wgpu::ExternalImageSource::ImageBitmap(face), &cube.texture, layer as u32, size, size);
                }
                Loaded::Pano { probe, pano: Pano::Cube(cube) }
            }
            Fetched::Tile { probe, size, slot, x, y, image } => {
                Loaded::Tile { probe, size, slot, x, y, pixels: crate::panorama::TilePixels::Bitmap(image) }
            }
            Fetched::Equirect { probe, image } => {
                let limit = gpu.device.limits().max_texture_dimension_2d;
                let (w, h) = (image.width().min(limit), image.height().min(limit));
                let t = VideoTexture::new(&gpu.device, w, h);
                copy_image(gpu, wgpu::ExternalImageSource::ImageBitmap(image), &t.texture, 0, w, h);
                Loaded::Pano { probe, pano: Pano::Equirect(t) }
            }
            Fetched::Thumbnail { probe, image } => {
                if probe < overlay.thumb_count {
                    copy_image(gpu, wgpu::ExternalImageSource::ImageBitmap(image), &overlay.thumbs, probe, THUMB_W, THUMB_H);
                }
                Loaded::Thumbnail { probe }
            }
            Fetched::ProxyBytes { level, part, file, bytes, seen, probes } => {
                let started = page_ms();
                let decoded = crate::dollhouse::decode_level(&file, &bytes, seen.as_ref().map(|(f, b)| (f.as_str(), b.as_slice())), probes);
                // The longest the main thread was held by one part's decoding, for the benchmark.
                let ms = page_ms() - started;
                self.decode_ms[level.min(1)] = self.decode_ms[level.min(1)].max(ms);
                set_status(&format!("proxy_decode_ms_{}", level.min(1)), &self.decode_ms[level.min(1)].into());
                match decoded {
                    Ok((mesh, seen)) => Loaded::Proxy { level, part, mesh, seen },
                    Err((what, error)) => Loaded::Failed { what, error, probe: None },
                }
            }
            Fetched::StreamStart { base, bytes, seen, probes } => {
                match crate::dollhouse::Refining::new(&base, &bytes, seen.as_ref().map(|(f, b)| (f.as_str(), b.as_slice())), probes) {
                    Ok(r) => {
                        self.refining = Some(r);
                        return None;
                    }
                    Err((what, error)) => Loaded::Failed { what, error, probe: None },
                }
            }
            Fetched::Packet { level, file, bytes } => {
                let started = page_ms();
                let applied = self.refining.as_mut()?.apply(&file, &bytes);
                // The longest the main thread was held by one packet, for the benchmark.
                self.decode_ms[0] = self.decode_ms[0].max(page_ms() - started);
                set_status("proxy_decode_ms_0", &self.decode_ms[0].into());
                match applied {
                    // The mesh is handed over once, after this frame's packets.
                    Ok(()) => {
                        self.refined = Some(level);
                        return None;
                    }
                    Err((what, error)) => {
                        self.refining = None;
                        Loaded::Failed { what, error, probe: None }
                    }
                }
            }
            Fetched::DepthMap { probe, map } => Loaded::DepthMap { probe, map },
            Fetched::DepthCube { probe, cube } => Loaded::DepthCube { probe, cube },
            Fetched::Failed { what, error, probe } => Loaded::Failed { what, error, probe },
        })
    }

    fn url(&self, file: &str) -> String {
        format!("{}{file}", self.base)
    }

    fn spawn(&self, task: impl std::future::Future<Output = Fetched> + 'static) {
        let done = self.done.clone();
        wasm_bindgen_futures::spawn_local(async move {
            let result = task.await;
            done.borrow_mut().push(result);
        });
    }
}

impl Platform for WebPlatform {
    fn load_cube(&mut self, probe: u32, size: u32, faces: &[String; 6]) {
        // The six faces are fetched and decoded at once; the last to arrive hands in the cube.
        let slots: Rc<RefCell<Vec<Option<FaceResult>>>> = Rc::new(RefCell::new((0..6).map(|_| None).collect()));
        for (i, file) in faces.iter().enumerate() {
            let (file, url, slots, done) = (file.clone(), self.url(file), slots.clone(), self.done.clone());
            wasm_bindgen_futures::spawn_local(async move {
                let result = match bitmap(url, None).await {
                    Ok(b) if (b.width(), b.height()) == (size, size) => Ok(b),
                    Ok(b) => Err(Fetched::Failed {
                        what: file,
                        error: format!("is {}×{}, but graph.json says {size}×{size}", b.width(), b.height()),
                        probe: Some(probe),
                    }),
                    Err(error) => Err(Fetched::Failed { what: file, error, probe: Some(probe) }),
                };
                let mut slots = slots.borrow_mut();
                slots[i] = Some(result);
                if slots.iter().all(Option::is_some) {
                    let results: Vec<_> = slots.drain(..).flatten().collect();
                    let mut faces = Vec::with_capacity(6);
                    for r in results {
                        match r {
                            Ok(b) => faces.push(b),
                            Err(failed) => return done.borrow_mut().push(failed),
                        }
                    }
                    done.borrow_mut().push(Fetched::Cube { probe, size, faces });
                }
            });
        }
    }

    fn load_tile(&mut self, probe: u32, size: u32, slot: usize, x: u32, y: u32, file: &str) {
        let (file, url) = (file.to_string(), self.url(file));
        self.spawn(async move {
            match bitmap(url, None).await {
                Ok(image) => Fetched::Tile { probe, size, slot, x, y, image },
                Err(error) => Fetched::Failed { what: file, error, probe: None },
            }
        });
    }

    fn load_equirect(&mut self, probe: u32, file: &str) {
        let (file, url) = (file.to_string(), self.url(file));
        self.spawn(async move {
            match bitmap(url, None).await {
                Ok(image) => Fetched::Equirect { probe, image },
                Err(error) => Fetched::Failed { what: file, error, probe: Some(probe) },
            }
        });
    }

    fn load_thumbnail(&mut self, probe: u32, file: &str) {
        let (file, url) = (file.to_string(), self.url(file));
        self.spawn(async move {
            match bitmap(url, Some((THUMB_W, THUMB_H))).await {
                Ok(image) => Fetched::Thumbnail { probe, image },
                Err(error) => Fetched::Failed { what: file, error, probe: None },
            }
        });
    }

    fn load_proxy(&mut self, level: usize, part: usize, mesh: &str, seen: Option<&str>, probes: u32) {
        // Fetched here, decoded in `poll`, one part between two frames.
        let (mesh, seen) = (mesh.to_string(), seen.map(str::to_string));
        let (mesh_bytes, seen_bytes) = (fetch_bytes(&self.url(&mesh)), seen.as_deref().map(|f| fetch_bytes(&self.url(f))));
        self.spawn(async move {
            let fetched = async {
                let m = mesh_bytes.await.map_err(|e| (mesh.clone(), e))?;
                let s = match (seen, seen_bytes) {
                    (Some(f), Some(bytes)) => Some((f.clone(), bytes.await.map_err(|e| (f, e))?)),
                    _ => None,
                };
                Ok::<_, (String, String)>((m, s))
            };
            match fetched.await {
                Ok((bytes, seen)) => Fetched::ProxyBytes { level, part, file: mesh, bytes, seen, probes },
                Err((what, error)) => Fetched::Failed { what, error, probe: None },
            }
        });
    }

    fn load_stream(&mut self, stream: &exploremaps_format::ProxyStream, base: &exploremaps_format::ProxyLevel, probes: u32) {
        // All requests leave now; the packets are handed over in order, and
        // `poll` applies one between two frames.
        let base_bytes = fetch_bytes(&self.url(&base.file));
        let seen = base.seen.clone().map(|f| (fetch_bytes(&self.url(&f)), f));
        let base = base.file.clone();
        let files: Vec<_> = stream.files().into_iter().map(|(file, ks)| (fetch_bytes(&self.url(&file)), file, ks)).collect();
        let stream = stream.clone();
        let done = self.done.clone();
        wasm_bindgen_futures::spawn_local(async move {
            let start = async {
                let bytes = base_bytes.await.map_err(|e| (base.clone(), e))?;
                let seen = match seen {
                    Some((bytes, f)) => Some((f.clone(), bytes.await.map_err(|e| (f, e))?)),
                    None => None,
                };
                Ok::<_, (String, String)>(Fetched::StreamStart { base, bytes, seen, probes })
            };
            match start.await {
                Ok(f) => done.borrow_mut().push(f),
                Err((what, error)) => return done.borrow_mut().push(Fetched::Failed { what, error, probe: None }),
            }
            for (bytes, file, ks) in files {
                let bytes = match bytes.await {
                    Ok(b) => b,
                    Err(error) => return done.borrow_mut().push(Fetched::Failed { what: file, error, probe: None }),
                };
                for k in ks {
                    match stream.packets[k].slice(&bytes) {
                        Ok(p) => done.borrow_mut().push(Fetched::Packet { level: stream.level_after(k), file: file.clone(), bytes: p.to_vec() }),
                        Err(error) => return done.borrow_mut().push(Fetched::Failed { what: file, error, probe: None }),
                    }
                }
            }
        });
    }

    fn load_depth_map(&mut self, probe: u32, file: &str, probes: u32) {
        let (file, url) = (file.to_string(), self.url(file));
        self.spawn(async move {
            match fetch_bytes(&url).await.and_then(|b| exploremaps_format::depthmap::DepthMap::decode(&b, probes).map_err(|e| e.to_string())) {
                Ok(map) => Fetched::DepthMap { probe, map },
                Err(error) => Fetched::Failed { what: file, error, probe: None },
            }
        });
    }

    fn load_depth_cube(&mut self, probe: u32, file: &str) {
        let (file, url) = (file.to_string(), self.url(file));
        self.spawn(async move {
            match fetch_bytes(&url).await.and_then(|b| exploremaps_format::depthcube::DepthCube::decode(&b).map_err(|e| e.to_string())) {
                Ok(cube) => Fetched::DepthCube { probe, cube },
                Err(error) => Fetched::Failed { what: file, error, probe: None },
            }
        });
    }

    fn poll(&mut self, gpu: &Gpu, overlay: &OverlayPass) -> Vec<Loaded> {
        let fetched: Vec<Fetched> = self.done.borrow_mut().drain(..).collect();
        // Proxy parts and packets are decoded, in the order they came, until
        // a few milliseconds of this frame are spent (at least one a frame);
        // the others wait for the next.
        let started = page_ms();
        let heavy = |f: &Fetched| matches!(f, Fetched::ProxyBytes { .. } | Fetched::StreamStart { .. } | Fetched::Packet { .. });
        // The next one is started when the last one's time still fits.
        let (mut last_ms, mut later, mut out) = (None, Vec::new(), Vec::new());
        for f in fetched {
            if heavy(&f) {
                if !later.is_empty() || last_ms.is_some_and(|ms| page_ms() - started + ms > DECODE_BUDGET_MS) {
                    later.push(f);
                    continue;
                }
                let t = page_ms();
                out.extend(self.take(f, gpu, overlay));
                last_ms = Some(page_ms() - t);
                continue;
            }
            out.extend(self.take(f, gpu, overlay));
        }
        self.done.borrow_mut().extend(later);
        if let (Some(level), Some(r)) = (self.refined.take(), &self.refining) {
            let (mesh, seen) = r.snapshot();
            out.push(Loaded::Refined { level, mesh, seen });
        }
        out
    }

    fn play_video(&mut self, file: &str, reversed: bool) {
        self.video.set_src(&self.url(file));
        self.playing = Some(reversed);
        if !reversed {
            let _ = self.video.play();
        }
    }

    fn stop_video(&mut self) {
        self.playing = None;
        let _ = self.video.pause();
    }

    fn video_frame(&mut self, gpu: &Gpu, t: f32) -> Result<Option<&VideoTexture>, String> {
        let Some(reversed) = self.playing else { return Ok(None) };
        let v = self.video.clone();
        if let Some(e) = v.error() {
            self.playing = None;
            return Err(format!("{} (code {})", e.message(), e.code()));
        }
        // The frame the element has now (HAVE_CURRENT_DATA: one can be copied)…
        let (w, h) = (v.video_width(), v.video_height());
        if v.ready_state() >= 2 && w > 0 && h > 0 {
            if self.video_texture.as_ref().is_none_or(|t| (t.width, t.height) != (w, h)) {
                self.video_texture = Some(VideoTexture::new(&gpu.device, w, h));
            }
            let texture = self.video_texture.as_ref().expect("made above");
            copy_image(gpu, wgpu::ExternalImageSource::HTMLVideoElement(v.clone()), &texture.texture, 0, w, h);
            if !v.seeking() && v.current_time() != self.video_time {
                self.video_time = v.current_time();
                self.video_frames += 1;
                set_status("video_frames", &self.video_frames.into());
            }
        }
        // …then the next one asked for: forward playback runs by itself;
        // reversed is seeked frame by frame, and either is pulled back in
        // step with the travel when it drifts.
        let duration = v.duration();
        if duration.is_finite() && duration > 0.0 && !v.seeking() {
            let wanted = if reversed { (1.0 - f64::from(t)) * duration } else { f64::from(t) * duration };
            if reversed || (v.current_time() - wanted).abs() > 0.25 {
                v.set_current_time(wanted.min(duration - 0.001));
            }
        }
        Ok(self.video_texture.as_ref())
    }

    fn show_message(&mut self, text: &str) {
        self.message = Some(text.to_string());
        show(text);
    }

    fn link_changed(&mut self, link: &Link) {
        let fragment = format!("#{}", link.to_fragment());
        let _ = window().history().and_then(|h| h.replace_state_with_url(&JsValue::NULL, "", Some(&fragment)));
    }
}

struct State {
    app: App,
    platform: WebPlatform,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    view_format: wgpu::TextureFormat,
    canvas: web_sys::HtmlCanvasElement,
    last_ms: f64,
    first_frame_logged: bool,
    /// Frames drawn as glides so far.
    glide_frames: u32,
    /// The proxy level the dollhouse last showed.
    dollhouse_level: Option<usize>,
    /// A headset's session, while one runs (it draws instead of the window).
    xr: Option<xr::Session>,
}

impl State {
    /// Matches the drawing buffer to the canvas's size on screen.
    fn fit(&mut self) {
        let dpr = window().device_pixel_ratio().max(1.0);
        let limit = self.app.gpu().device.limits().max_texture_dimension_2d;
        let w = ((f64::from(self.canvas.client_width()) * dpr).round() as u32).clamp(1, limit);
        let h = ((f64::from(self.canvas.client_height()) * dpr).round() as u32).clamp(1, limit);
        if (w, h) != (self.config.width, self.config.height) {
            self.canvas.set_width(w);
            self.canvas.set_height(h);
            self.config.width = w;
            self.config.height = h;
            self.surface.configure(&self.app.gpu().device, &self.config);
        }
        self.app.resize(w, h, dpr as f32);
    }

    fn frame(&mut self, now_ms: f64) {
        if self.xr.is_some() {
            return;
        }
        self.fit();
        let dt = ((now_ms - self.last_ms) / 1000.0).clamp(0.0, 0.1) as f32;
        self.last_ms = now_ms;
        self.app.update(dt, &mut self.platform);
        if self.app.waiting_for_first_frame() {
            return;
        }
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            _ => {
                self.surface.configure(&self.app.gpu().device, &self.config);
                return;
            }
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor { format: Some(self.view_format), ..Default::default() });
        let commands = self.app.render(&view, &mut self.platform);
        let queue = self.app.gpu().queue.clone();
        queue.submit([commands]);
        queue.present(frame);
        if self.app.shown_panorama && !self.first_frame_logged {
            self.first_frame_logged = true;
            let ms = page_ms();
            web_sys::console::info_1(&format!("first panorama: {ms:.0} ms after navigation start").into());
            set_status("first_panorama_ms", &ms.into());
        }
        set_status("probe", &self.app.nav.probe().into());
        set_status("yaw", &self.app.nav.view.yaw.to_degrees().into());
        let (asked, arrived) = self.app.tile_counts();
        set_status("tiles_requested", &(asked as u32).into());
        set_status("tiles_in", &(arrived as u32).into());
        set_status("moving", &self.app.nav.progress().is_some().into());
        let dollhouse = self.app.mode == Mode::Dollhouse;
        set_status("dollhouse", &dollhouse.into());
        set_status("flying", &self.app.flying().into());
        set_status("point_to_go", &self.app.point_to_go_ready().into());
        self.glide_frames += u32::from(self.app.gliding());
        set_status("glide_frames", &self.glide_frames.into());
        // The first dollhouse frame with a proxy, and the first with its finest level.
        let level = self.app.proxy.as_ref().map(|m| m.level);
        if dollhouse && level.is_some() && level != self.dollhouse_level {
            if self.dollhouse_level.is_none() {
                mark("dollhouse_first");
            }
            if level == Some(0) {
                mark("dollhouse_full");
            }
            self.dollhouse_level = level;
        }
    }
}

/// Records when a start-up step ended (ms since navigation) in
/// `window.exploremaps.timeline`, for the benchmark.
fn mark(step: &str) {
    let ms = page_ms();
    set_status(&format!("t_{step}"), &ms.into());
}

/// Exposes a little state on `window.exploremaps` for tests and benchmarks.
fn set_status(key: &str, value: &JsValue) {
    let w = window();
    let status = js_sys::Reflect::get(&w, &"exploremaps".into()).ok().filter(|v| v.is_object()).unwrap_or_else(|| {
        let o: JsValue = js_sys::Object::new().into();
        let _ = js_sys::Reflect::set(&w, &"exploremaps".into(), &o);
        o
    });
    let _ = js_sys::Reflect::set(&status, &key.into(), value);
}

fn listen<E: JsCast + 'static>(target: &web_sys::EventTarget, name: &str, state: &Rc<RefCell<State>>, handler: impl Fn(&mut State, E) + 'static) {
    let state = state.clone();
    let closure = Closure::<dyn FnMut(web_sys::Event)>::new(move |e: web_sys::Event| {
        if let Ok(mut s) = state.try_borrow_mut() {
            handler(&mut s, e.unchecked_into());
        }
    });
    let _ = target.add_event_listener_with_callback(name, closure.as_ref().unchecked_ref());
    closure.forget();
}

fn pointer(s: &State, e: &web_sys::PointerEvent) -> (u64, f32, f32) {
    let dpr = window().device_pixel_ratio() as f32;
    let rect = s.canvas.get_bounding_client_rect();
    (e.pointer_id() as u64, (e.client_x() as f32 - rect.left() as f32) * dpr, (e.client_y() as f32 - rect.top() as f32) * dpr)
}

/// Starts the viewer on `canvas_id` for the bundle at `bundle_url` (ending in `/`).
#[wasm_bindgen]
pub async fn start(canvas_id: String, bundle_url: String) -> Result<(), JsValue> {
    match run(&canvas_id, &bundle_url).await {
        Ok(()) => Ok(()),
        Err(e) => {
            show(&e);
            set_status("error", &e.clone().into());
            Err(e.into())
        }
    }
}

async fn run(canvas_id: &str, base: &str) -> Result<(), String> {
    mark("wasm_ready");
    let graph = fetch_graph(base).await?;
    mark("graph");
    let link = Link::parse(&window().location().hash().unwrap_or_default()).unwrap_or_else(|e| {
        show(&format!("the link's {e}; starting at the first probe"));
        Link::default()
    });
    let probe = link.probe.filter(|&p| (p as usize) < graph.probes.len());
    let document = window().document().ok_or("no document")?;
    let canvas: web_sys::HtmlCanvasElement = document
        .get_element_by_id(canvas_id)
        .ok_or_else(|| format!("no canvas #{canvas_id}"))?
        .dyn_into()
        .map_err(|_| format!("#{canvas_id} is not a canvas"))?;
    // A headset needs WebGL2, on a context made for it before wgpu opens it.
    let xr_context = if xr::supported().await { xr::compatible_context(&canvas) } else { None };
    let (gpu, surface, config) = open_gpu(&canvas, xr_context.is_some()).await?;
    let mut platform = WebPlatform {
        base: base.to_string(),
        done: Rc::default(),
        video: hidden_video(&document)?,
        video_texture: None,
        playing: None,
        message: None,
        faces_marked: false,
        video_time: -1.0,
        video_frames: 0,
        decode_ms: [0.0; 2],
        refining: None,
        refined: None,
    };
    let nav = Navigator::new(graph, probe, 1).map_err(|e| e.to_string())?;
    // Phones: faces up to 1024 and a smaller texture budget. Headsets: an
    // eye's 20-odd pixels a degree need the 2048 faces (as tiles, those in
    // view), in half a desktop's budget, as standalone headsets share memory.
    let small = canvas.client_width().min(canvas.client_height()) < 600;
    let budget_bytes = match (small, xr_context.is_some()) {
        (true, _) => 96 << 20,
        (false, true) => 128 << 20,
        (false, false) => 256 << 20,
    };
    let max_face = if small && xr_context.is_none() { 1024 } else { 2048 };
    let options = Options { budget_bytes, max_face, show_map: !small, tour: false };
    let view_format = gpu.format;
    let app = App::new(gpu, nav, Some(&link), options, &mut platform);
    mark("app");
    let state = Rc::new(RefCell::new(State {
        app,
        platform,
        surface,
        config,
        view_format,
        canvas: canvas.clone(),
        last_ms: 0.0,
        first_frame_logged: false,
        glide_frames: 0,
        dollhouse_level: None,
        xr: None,
    }));
    listen_to_input(canvas.as_ref(), &state);
    if let Some(gl) = xr_context {
        xr::offer(&state, gl);
    }
    start_frame_loop(state);
    Ok(())
}

/// The bundle's graph.json, read and validated.
async fn fetch_graph(base: &str) -> Result<Graph, String> {
    let graph_url = format!("{base}{GRAPH_FILE}");
    let text = JsFuture::from(fetch(&graph_url).await.map_err(|e| format!("{graph_url}: {e}"))?.text().map_err(js_error)?).await.map_err(js_error)?;
    let graph =
        Graph::from_json(&text.as_string().unwrap_or_default()).map_err(|e| format!("{graph_url}: {}", exploremaps_format::error_chain(&e)))?;
    if graph.probes.is_empty() {
        return Err(format!("{graph_url}: the bundle has no probes to show"));
    }
    Ok(graph)
}

/// WebGPU when the browser has it (unless `webgl2_only`), else WebGL2, drawing on `canvas`.
async fn open_gpu(
    canvas: &web_sys::HtmlCanvasElement,
    webgl2_only: bool,
) -> Result<(Gpu, wgpu::Surface<'static>, wgpu::SurfaceConfiguration), String> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = if webgl2_only { wgpu::Backends::GL } else { wgpu::Backends::BROWSER_WEBGPU | wgpu::Backends::GL };
    let instance = wgpu::util::new_instance_with_webgpu_detection(desc).await;
    let surface = instance.create_surface(wgpu::SurfaceTarget::Canvas(canvas.clone())).map_err(|e| format!("cannot draw on the canvas: {e}"))?;
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions { compatible_surface: Some(&surface), ..Default::default() })
        .await
        .map_err(|e| format!("this browser offers neither WebGPU nor WebGL2 ({e})"))?;
    let (w, h) = (canvas.width().max(1), canvas.height().max(1));
    let (gpu, config) = Gpu::open(&adapter, &surface, w, h).await?;
    mark("device");
    set_status("backend", &format!("{:?}", adapter.get_info().backend).into());
    Ok((gpu, surface, config))
}

/// The `<video>` element paths play in: attached (invisibly), so the
/// browser decodes its frames.
fn hidden_video(document: &web_sys::Document) -> Result<web_sys::HtmlVideoElement, String> {
    let video: web_sys::HtmlVideoElement = document.create_element("video").map_err(js_error)?.unchecked_into();
    video.set_muted(true);
    video.set_preload("auto");
    let _ = video.set_attribute("playsinline", "");
    let _ = video.set_attribute("style", "position:fixed;left:0;top:0;width:1px;height:1px;opacity:0;pointer-events:none");
    if let Some(body) = document.body() {
        let _ = body.append_child(&video);
    }
    Ok(video)
}

/// Pointer, wheel and key events on the canvas (keys on the window) to the app.
fn listen_to_input(target: &web_sys::EventTarget, state: &Rc<RefCell<State>>) {
    listen(target, "pointerdown", state, |s, e: web_sys::PointerEvent| {
        let _ = s.canvas.set_pointer_capture(e.pointer_id());
        let (id, x, y) = pointer(s, &e);
        s.app.input(Input::PointerDown { id, x, y }, &mut s.platform);
    });
    listen(target, "pointermove", state, |s, e: web_sys::PointerEvent| {
        let (id, x, y) = pointer(s, &e);
        s.app.input(Input::PointerMove { id, x, y }, &mut s.platform);
    });
    for name in ["pointerup", "pointercancel"] {
        listen(target, name, state, |s, e: web_sys::PointerEvent| {
            let (id, x, y) = pointer(s, &e);
            s.app.input(Input::PointerUp { id, x, y }, &mut s.platform);
        });
    }
    listen(target, "wheel", state, |s, e: web_sys::WheelEvent| {
        e.prevent_default();
        s.app.input(Input::Wheel(-(e.delta_y() as f32) / 100.0), &mut s.platform);
    });
    listen(window().as_ref(), "keydown", state, |s, e: web_sys::KeyboardEvent| {
        if let Some(k) = Key::from_code(&e.code()) {
            e.prevent_default();
            s.app.input(Input::Key(k), &mut s.platform);
        }
    });
}

/// The frame loop: requestAnimationFrame, every frame (the view may move at
/// any time), for the page's lifetime.
fn start_frame_loop(state: Rc<RefCell<State>>) {
    let tick: FrameLoop = Rc::default();
    let next = tick.clone();
    *tick.borrow_mut() = Some(Closure::new(move |now: f64| {
        state.borrow_mut().frame(now);
        if let Some(f) = next.borrow().as_ref() {
            let _ = window().request_animation_frame(f.as_ref().unchecked_ref());
        }
    }));
    let _ = window().request_animation_frame(tick.borrow().as_ref().expect("set above").as_ref().unchecked_ref());
    std::mem::forget(tick);
}
