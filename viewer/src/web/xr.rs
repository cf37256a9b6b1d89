//! Headsets: a WebXR `immersive-vr` session in the web viewer.
//!
//! wgpu has no WebXR API, so a session draws through wgpu's WebGL2 backend.
//! Where the browser offers `immersive-vr`, the page creates the canvas's
//! WebGL2 context itself with `xrCompatible: true` before wgpu opens it
//! (`getContext` hands wgpu that same context) and the viewer keeps to
//! WebGL2. In each of the session's frames wgpu draws both eyes into the
//! canvas, sized as the session's layer, each eye in the layer's viewport for
//! it, and presents; in the same callback the canvas's drawing buffer is
//! blitted into the layer's opaque framebuffer (where the runtime gives none,
//! as emulators do, the canvas is the layer).
//!
//! The panorama is at infinity, so only the head's rotation turns it: the
//! eyes see it through their own frusta, the horizon where the world's is,
//! facing at first where the window faced.

use super::{set_status, window, State};
use crate::app::Eye;
use crate::headset::Goal;
use crate::panorama::Lens;
use glam::{Mat4, Quat};
use std::cell::RefCell;
use std::rc::Rc;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;
use web_sys::{WebGl2RenderingContext as Gl, XrFrame, XrReferenceSpace, XrSession, XrSessionMode, XrView, XrWebGlLayer};

/// A session under way.
pub(super) struct Session {
    session: XrSession,
    space: XrReferenceSpace,
    layer: XrWebGlLayer,
    /// Turns the session's space (−Z ahead at the start) to face where the window did.
    heading: Quat,
    /// The window's field of view, given back when the session ends.
    window_fov_y: f32,
    frames: u32,
}

/// Where a controller points (world direction), from its target ray's pose in `frame`.
fn ray_of(frame: &XrFrame, source: &web_sys::XrInputSource, space: &XrReferenceSpace, heading: Quat) -> Option<glam::Vec3> {
    let pose = frame.get_pose(&source.target_ray_space(), space)?;
    Some(heading * orientation(&pose.transform()) * glam::Vec3::NEG_Z)
}

/// The pointing controller's ray, if one points (the right hand's first).
fn controller_ray(frame: &XrFrame, session: &XrSession, space: &XrReferenceSpace, heading: Quat) -> Option<glam::Vec3> {
    let sources = session.input_sources();
    let mut pointers: Vec<web_sys::XrInputSource> =
        (0..sources.length()).filter_map(|i| sources.get(i)).filter(|s| s.target_ray_mode() == web_sys::XrTargetRayMode::TrackedPointer).collect();
    pointers.sort_by_key(|s| s.handedness() != web_sys::XrHandedness::Right);
    pointers.iter().find_map(|s| ray_of(frame, s, space, heading))
}

/// Whether the browser can start an `immersive-vr` session (false, quietly,
/// where it has no WebXR).
pub(super) async fn supported() -> bool {
    let navigator = window().navigator();
    if !js_sys::Reflect::has(&navigator, &"xr".into()).unwrap_or(false) {
        return false;
    }
    let promise = navigator.xr().is_session_supported(XrSessionMode::ImmersiveVr);
    JsFuture::from(promise).await.ok().and_then(|v| v.as_bool()).unwrap_or(false)
}

/// The canvas's WebGL2 context, created XR-compatible (and without
/// antialiasing, as wgpu asks) before wgpu opens the same context.
pub(super) fn compatible_context(canvas: &web_sys::HtmlCanvasElement) -> Option<Gl> {
    let options = js_sys::Object::new();
    let _ = js_sys::Reflect::set(&options, &"xrCompatible".into(), &true.into());
    let _ = js_sys::Reflect::set(&options, &"antialias".into(), &false.into());
    canvas.get_context_with_context_options("webgl2", &options).ok().flatten()?.dyn_into().ok()
}

/// Shows the page's Enter VR button and starts or ends a session on a click.
pub(super) fn offer(state: &Rc<RefCell<State>>, gl: Gl) {
    let Some(button) = window().document().and_then(|d| d.get_element_by_id("enter-vr")) else { return };
    let _ = button.remove_attribute("hidden");
    let state = state.clone();
    let click = Closure::<dyn FnMut()>::new(move || {
        let running = state.borrow().xr.as_ref().map(|x| x.session.clone());
        match running {
            Some(session) => drop(session.end()),
            None => wasm_bindgen_futures::spawn_local(enter(state.clone(), gl.clone())),
        }
    });
    let _ = button.add_event_listener_with_callback("click", click.as_ref().unchecked_ref());
    click.forget();
}

/// Starts a session: the layer on the canvas's context, the local space,
/// the frame loop; its end gives the window back.
async fn enter(state: Rc<RefCell<State>>, gl: Gl) {
    if let Err(e) = start(&state, &gl).await {
        super::show(&format!("cannot enter VR: {e}"));
    }
}

async fn start(state: &Rc<RefCell<State>>, gl: &Gl) -> Result<(), String> {
    let xr = window().navigator().xr();
    let session: XrSession = JsFuture::from(xr.request_session(XrSessionMode::ImmersiveVr)).await.map_err(super::js_error)?.unchecked_into();
    let init = web_sys::XrWebGlLayerInit::new();
    init.set_antialias(false);
    let layer = XrWebGlLayer::new_with_web_gl2_rendering_context_and_layer_init(&session, gl, &init).map_err(super::js_error)?;
    let render_state = web_sys::XrRenderStateInit::new();
    render_state.set_base_layer(Some(&layer));
    session.update_render_state_with_state(&render_state);
    let space = JsFuture::from(session.request_reference_space(web_sys::XrReferenceSpaceType::Local)).await.map_err(super::js_error)?;
    {
        let mut s = state.borrow_mut();
        let view = s.app.nav.view;
        s.xr = Some(Session {
            session: session.clone(),
            space: space.unchecked_into(),
            layer,
            heading: Quat::from_rotation_y(-view.yaw),
            window_fov_y: view.fov_y,
            frames: 0,
        });
        set_status("xr", &true.into());
    }
    let ended = state.clone();
    let on_end = Closure::<dyn FnMut()>::new(move || {
        let mut s = ended.borrow_mut();
        if let Some(x) = s.xr.take() {
            s.app.nav.view.fov_y = x.window_fov_y;
        }
        set_status("xr", &false.into());
    });
    session.set_onend(Some(on_end.as_ref().unchecked_ref()));
    on_end.forget();
    // A controller's select goes where it points.
    let selecting = state.clone();
    let on_select = Closure::<dyn FnMut(web_sys::XrInputSourceEvent)>::new(move |e: web_sys::XrInputSourceEvent| {
        let mut s = selecting.borrow_mut();
        let Some(xr) = &s.xr else { return };
        let ray = ray_of(&e.frame(), &e.input_source(), &xr.space, xr.heading);
        if let Some(ray) = ray {
            s.app.point(Some(ray), ray, 0.0);
            s.app.select();
        }
    });
    session.set_onselect(Some(on_select.as_ref().unchecked_ref()));
    on_select.forget();
    request_frames(state.clone(), session, gl.clone());
    Ok(())
}

type XrLoop = Rc<RefCell<Option<Closure<dyn FnMut(f64, XrFrame)>>>>;

/// The session's frame loop, for as long as the session lasts.
fn request_frames(state: Rc<RefCell<State>>, session: XrSession, gl: Gl) {
    let tick: XrLoop = Rc::default();
    let next = tick.clone();
    *tick.borrow_mut() = Some(Closure::new(move |now: f64, frame: XrFrame| {
        let mut s = state.borrow_mut();
        if s.xr.is_none() {
            next.borrow_mut().take();
            return;
        }
        s.xr_frame(now, &frame, &gl);
        if let Some(f) = next.borrow().as_ref() {
            frame.session().request_animation_frame(f.as_ref().unchecked_ref());
        }
    }));
    session.request_animation_frame(tick.borrow().as_ref().expect("set above").as_ref().unchecked_ref());
}

impl State {
    /// One frame of the session: the head looks, the app moves on, both eyes
    /// are drawn, and the drawing goes to the layer.
    fn xr_frame(&mut self, now_ms: f64, frame: &XrFrame, gl: &Gl) {
        let Some(xr) = &self.xr else { return };
        let Some(pose) = frame.get_viewer_pose(&xr.space) else { return };
        let (layer, heading, session, space) = (xr.layer.clone(), xr.heading, xr.session.clone(), xr.space.clone());
        let (width, height) = (layer.framebuffer_width().max(1), layer.framebuffer_height().max(1));
        self.size_to(width, height);
        let eyes: Vec<Eye> = pose
            .views()
            .iter()
            .filter_map(|view| {
                let view: XrView = view.unchecked_into();
                // A mono runtime gives the second eye an empty viewport.
                let port = layer.get_viewport(&view).filter(|p| p.width() > 0 && p.height() > 0)?;
                let projection = Mat4::from_cols_slice(&view.projection_matrix());
                let lens = Lens::of_eye(heading * orientation(&view.transform()), &projection);
                // The layer's viewports count y from the bottom; wgpu's from the top.
                let top = height as i32 - port.y() - port.height();
                Some(Eye { viewport: [port.x() as f32, top as f32, port.width() as f32, port.height() as f32], lens })
            })
            .collect();
        let Some(first) = eyes.first() else { return };
        let fov_y = 2.0 * first.lens.scale[1].atan();
        let (eye_w, eye_h) = (first.viewport[2] as u32, first.viewport[3] as u32);
        let head = heading * orientation(&pose.transform());
        self.app.look(head, fov_y, (eye_w, eye_h));
        let dt = ((now_ms - self.last_ms) / 1000.0).clamp(0.0, 0.1) as f32;
        self.last_ms = now_ms;
        let controller = controller_ray(frame, &session, &space, heading);
        self.app.point(controller, head * glam::Vec3::NEG_Z, dt);
        self.app.update(dt, &mut self.platform);
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            _ => {
                self.surface.configure(&self.app.gpu().device, &self.config);
                return;
            }
        };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor { format: Some(self.view_format), ..Default::default() });
        self.app.render_eyes(&view, &eyes, &mut self.platform);
        self.app.gpu().queue.clone().present(texture);
        if let Some(framebuffer) = layer.framebuffer() {
            let (w, h) = (width as i32, height as i32);
            gl.bind_framebuffer(Gl::READ_FRAMEBUFFER, None);
            gl.bind_framebuffer(Gl::DRAW_FRAMEBUFFER, Some(&framebuffer));
            gl.blit_framebuffer(0, 0, w, h, 0, 0, w, h, Gl::COLOR_BUFFER_BIT, Gl::NEAREST);
            gl.bind_framebuffer(Gl::DRAW_FRAMEBUFFER, None);
        }
        if let Some(xr) = &mut self.xr {
            xr.frames += 1;
            set_status("xr_frames", &xr.frames.into());
            set_status("xr_eyes", &(eyes.len() as u32).into());
        }
        let view = self.app.nav.view;
        set_status("probe", &self.app.nav.probe().into());
        set_status("yaw", &view.yaw.to_degrees().into());
        set_status("pitch", &view.pitch.to_degrees().into());
        set_status("moving", &self.app.nav.progress().is_some().into());
        set_status(
            "glide_frames",
            &{
                self.glide_frames += u32::from(self.app.gliding());
                self.glide_frames
            }
            .into(),
        );
        // The targets as a controller in the session's space must point: [goal, yaw°, pitch°].
        let targets = js_sys::Array::new();
        for t in self.app.targets() {
            let (yaw, pitch) = crate::navigation::yaw_pitch((heading.inverse() * t.direction).into());
            let goal = match t.goal {
                Goal::Path(p) => format!("path {p}"),
                Goal::Probe(p) => format!("probe {p}"),
            };
            targets.push(&js_sys::Array::of3(&goal.into(), &yaw.to_degrees().into(), &pitch.to_degrees().into()));
        }
        set_status("xr_targets", &targets);
    }

    /// The canvas and the surface at the layer's size.
    fn size_to(&mut self, width: u32, height: u32) {
        if (self.canvas.width(), self.canvas.height()) != (width, height) {
            self.canvas.set_width(width);
            self.canvas.set_height(height);
        }
        if (self.config.width, self.config.height) != (width, height) {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.app.gpu().device, &self.config);
        }
    }
}

/// A rigid transform's rotation.
fn orientation(transform: &web_sys::XrRigidTransform) -> Quat {
    let o = transform.orientation();
    Quat::from_xyzw(o.x() as f32, o.y() as f32, o.z() as f32, o.w() as f32).normalize()
}
