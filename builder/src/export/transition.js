// ExploreMaps transitions for tour viewers: plays a path's 360° video
// (equirectangular frames in world orientation, column 0 at yaw 0, row 0
// straight up) over the viewer, in perspective, turning from the view the
// visitor had to the arrival direction as ExploreMaps' own viewer does; or,
// where the path has no video, draws its glide (WebGL 2) as that viewer
// does: each panorama it passes raised into a mesh by its depth, drawn from
// the moving camera, the two around the camera blended by distance.
// Angles are radians: yaw 0 looks toward -Z, positive to the right; pitch
// positive looks up; fov is vertical.
(function () {
  "use strict";

  var VERTEX = "attribute vec2 p; varying vec2 ndc; void main() { ndc = p; gl_Position = vec4(p, 0.0, 1.0); }";
  var FRAGMENT = [
    "precision highp float;",
    "varying vec2 ndc;",
    "uniform sampler2D frame;",
    "uniform float yaw, pitch, tanHalf, aspect;",
    "const float PI = 3.141592653589793;",
    "void main() {",
    "  vec3 c = normalize(vec3(ndc.x * tanHalf * aspect, ndc.y * tanHalf, -1.0));",
    "  float y1 = c.y * cos(pitch) - c.z * sin(pitch);",
    "  float z1 = c.y * sin(pitch) + c.z * cos(pitch);",
    "  vec3 d = vec3(c.x * cos(yaw) - z1 * sin(yaw), y1, c.x * sin(yaw) + z1 * cos(yaw));",
    "  float u = fract(atan(d.x, -d.z) / (2.0 * PI) + 1.0);",
    "  float v = acos(clamp(d.y, -1.0, 1.0)) / PI;",
    "  gl_FragColor = texture2D(frame, vec2(u, v));",
    "}",
  ].join("\n");

  function smoothstep(t) {
    t = Math.min(Math.max(t, 0), 1);
    return t * t * (3 - 2 * t);
  }

  function wrap(a) {
    while (a > Math.PI) a -= 2 * Math.PI;
    while (a < -Math.PI) a += 2 * Math.PI;
    return a;
  }

  // ---- Glides ----------------------------------------------------------
  var MESH_VS = [
    "#version 300 es",
    "in vec3 p; uniform mat4 viewProj; out vec3 world;",
    "void main() { world = p; gl_Position = viewProj * vec4(p, 1.0); }",
  ].join("\n");
  // As the viewer's glide pass: colour from the source's cube along the
  // direction from it; alpha how squarely the source saw the triangle (a
  // rubber sheet across a depth step lies along its rays), and such a sheet
  // pushed behind everything sure.
  var MESH_FS = [
    "#version 300 es",
    "precision highp float;",
    "in vec3 world; uniform samplerCube cube; uniform vec4 probe; out vec4 colour;",
    "void main() {",
    "  vec3 d = world - probe.xyz;",
    "  vec3 n = cross(dFdx(world), dFdy(world));",
    "  float facing = abs(dot(n, d)) / max(length(n) * length(d), 1e-20);",
    "  float sure = smoothstep(probe.w, 3.0 * probe.w, facing);",
    "  colour = vec4(texture(cube, d).rgb, 0.02 + 0.98 * sure);",
    "  gl_FragDepth = sure > 0.5 ? gl_FragCoord.z : 1.0;",
    "}",
  ].join("\n");
  // Blends the two sources by where the camera is; where one's sure surface
  // lies well in front of the other's, the other steps back (not near its
  // own end, whose view is exact there).
  var BLEND_FS = [
    "#version 300 es",
    "precision highp float;",
    "uniform sampler2D a, b; uniform highp sampler2D da, db;",
    "uniform float t, tol, near, far;",
    "out vec4 colour;",
    "float dist(float z) { return 2.0 * near * far / (far + near - (2.0 * z - 1.0) * (far - near)); }",
    "float hides(float alpha, float nearer, float farther) { return alpha > 0.9 && nearer * (1.0 + tol) < farther ? 1.0 : 0.0; }",
    "void main() {",
    "  ivec2 at = ivec2(gl_FragCoord.xy);",
    "  vec4 pa = texelFetch(a, at, 0); vec4 pb = texelFetch(b, at, 0);",
    "  float za = dist(texelFetch(da, at, 0).r); float zb = dist(texelFetch(db, at, 0).r);",
    "  float wa = (1.0 - t) * pa.a * (1.0 - 0.98 * hides(pb.a, zb, za) * smoothstep(0.0, 0.25, t));",
    "  float wb = t * pb.a * (1.0 - 0.98 * hides(pa.a, za, zb) * smoothstep(0.0, 0.25, 1.0 - t));",
    "  colour = wa + wb > 0.0 ? vec4((pa.rgb * wa + pb.rgb * wb) / (wa + wb), 1.0) : vec4(0.0, 0.0, 0.0, 1.0);",
    "}",
  ].join("\n");
  var BLEND_VS = "#version 300 es\nin vec2 p; void main() { gl_Position = vec4(p, 0.0, 1.0); }";
  // The sky's distance and the far plane, in multiples of a depth cube's far
  // distance (twice the scene's diagonal): the sky stays put as the camera moves.
  var SKY = 25, FAR = 50;
  // As in the viewer: 5 %, and twice the lattice's cell angle.
  var TOLERANCE = 0.05;

  function linked(gl, vs, fs) {
    function shader(type, source) {
      var s = gl.createShader(type);
      gl.shaderSource(s, source);
      gl.compileShader(s);
      return s;
    }
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    return gl.getProgramParameter(p, gl.LINK_STATUS) ? p : null;
  }

  // The unit direction through image point (s, t) of cube face `face`
  // (+X, −X, +Y, −Y, +Z, −Z; s right, t down), as the bundle's format says.
  function cubeDirection(face, s, t) {
    var a = 2 * s - 1, b = 2 * t - 1;
    var d = [[1, -b, -a], [-1, -b, a], [a, 1, b], [a, -1, -b], [a, -b, 1], [-a, -b, -1]][face];
    var l = Math.hypot(d[0], d[1], d[2]);
    return [d[0] / l, d[1] / l, d[2] / l];
  }

  // A source's mesh: a vertex at each lattice corner where it sees
  // something (the sky far away), two triangles a cell.
  function sourceMesh(gl, source, codes) {
    var cells = source.cells, n = cells + 1, top = 65534;
    var positions = new Float32Array(6 * n * n * 3);
    var nearest = Infinity;
    var ratio = Math.log(source.far / source.near);
    for (var i = 0; i < 6 * n * n; i++) {
      var face = Math.floor(i / (n * n)), row = Math.floor(i / n) % n, column = i % n;
      var d = cubeDirection(face, column / cells, row / cells);
      var code = codes[i];
      var distance = code > 0 ? source.near * Math.exp(ratio * (code - 1) / top) : SKY * source.far;
      nearest = Math.min(nearest, distance);
      for (var k = 0; k < 3; k++) positions[3 * i + k] = source.position[k] + d[k] * distance;
    }
    var indices = new Uint32Array(36 * cells * cells);
    var m = 0;
    for (var f = 0; f < 6; f++) {
      for (var r = 0; r < cells; r++) {
        for (var c = 0; c < cells; c++) {
          var j = f * n * n + r * n + c;
          indices.set([j, j + 1, j + n + 1, j, j + n + 1, j + n], m);
          m += 6;
        }
      }
    }
    var vertices = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vertices);
    gl.bufferData(gl.ARRAY_BUFFER, positions, gl.STATIC_DRAW);
    var elements = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, elements);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    return { vertices: vertices, elements: elements, count: indices.length, nearest: nearest };
  }

  // Loads a source: its six faces into a cube map and its depth into a mesh.
  function loadSource(gl, source, base) {
    var images = source.faces.map(function (face) {
      return new Promise(function (resolve, reject) {
        var image = new Image();
        image.crossOrigin = "anonymous";
        image.onload = function () { resolve(image); };
        image.onerror = function () { reject(new Error(face + " did not load")); };
        image.src = base + face;
      });
    });
    var depth = fetch(base + source.depth).then(function (r) {
      if (!r.ok) throw new Error(source.depth + ": " + r.status);
      return r.arrayBuffer();
    });
    return Promise.all([Promise.all(images), depth]).then(function (loaded) {
      var texture = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_CUBE_MAP, texture);
      loaded[0].forEach(function (image, f) {
        gl.texImage2D(gl.TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, gl.RGB, gl.RGB, gl.UNSIGNED_BYTE, image);
      });
      gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
      var codes = new Uint16Array(loaded[1]);
      if (codes.length !== 6 * (source.cells + 1) * (source.cells + 1)) throw new Error(source.depth + " holds " + codes.length + " corners");
      var mesh = sourceMesh(gl, source, codes);
      mesh.texture = texture;
      mesh.position = source.position;
      mesh.cellAngle = Math.atan(2 / source.cells);
      return mesh;
    });
  }

  function target(gl, w, h) {
    var colour = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, colour);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, w, h, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    var depth = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, depth);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.DEPTH_COMPONENT32F, w, h, 0, gl.DEPTH_COMPONENT, gl.FLOAT, null);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    var fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, colour, 0);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.TEXTURE_2D, depth, 0);
    return { fb: fb, colour: colour, depth: depth };
  }

  // Column-major view-projection for a camera at `eye` looking along
  // (yaw, pitch), vertical field of view `fov`.
  function viewProjection(eye, yaw, pitch, fov, aspect, near, far) {
    var f = [Math.sin(yaw) * Math.cos(pitch), Math.sin(pitch), -Math.cos(yaw) * Math.cos(pitch)];
    var r = [Math.cos(yaw), 0, Math.sin(yaw)];
    var u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
    var dot = function (a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    var view = [r[0], u[0], -f[0], 0, r[1], u[1], -f[1], 0, r[2], u[2], -f[2], 0, -dot(r, eye), -dot(u, eye), dot(f, eye), 1];
    var c = 1 / Math.tan(fov / 2);
    var proj = [c / aspect, 0, 0, 0, 0, c, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, 2 * far * near / (near - far), 0];
    var out = new Float32Array(16);
    for (var col = 0; col < 4; col++) {
      for (var row = 0; row < 4; row++) {
        var sum = 0;
        for (var k = 0; k < 4; k++) sum += proj[k * 4 + row] * view[col * 4 + k];
        out[col * 4 + row] = sum;
      }
    }
    return out;
  }

  // The point at fraction `s` of a polyline's length.
  function along(polyline, s) {
    var lengths = [0];
    for (var i = 1; i < polyline.length; i++) {
      var a = polyline[i - 1], b = polyline[i];
      lengths.push(lengths[i - 1] + Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]));
    }
    var at = s * lengths[lengths.length - 1];
    for (var j = 1; j < polyline.length; j++) {
      if (at <= lengths[j] || j === polyline.length - 1) {
        var l = Math.max(lengths[j] - lengths[j - 1], 1e-12), k = Math.min(Math.max((at - lengths[j - 1]) / l, 0), 1);
        var p = polyline[j - 1], q = polyline[j];
        return [p[0] + (q[0] - p[0]) * k, p[1] + (q[1] - p[1]) * k, p[2] + (q[2] - p[2]) * k];
      }
    }
    return polyline[0];
  }

  function distance(a, b) {
    return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  }

  // Starts a glide over `container` (see `start`); null without WebGL 2.
  function startGlide(container, link, from, to, base) {
    var all = (window.EXPLOREMAPS_TOUR || {}).glide_sources || {};
    var canvas = document.createElement("canvas");
    var gl = canvas.getContext("webgl2", { alpha: false, antialias: false });
    var mesh = gl && linked(gl, MESH_VS, MESH_FS);
    var blend = gl && linked(gl, BLEND_VS, BLEND_FS);
    if (!mesh || !blend) return null;
    overlay(container, canvas);
    var quad = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, quad);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    var transition = { canvas: canvas, kind: "glide", frames: 0 };
    var closed = false;
    transition.close = function () {
      if (closed) return;
      closed = true;
      canvas.style.opacity = "0";
      setTimeout(function () { if (canvas.parentNode) canvas.parentNode.removeChild(canvas); }, 250);
    };
    var targets = null;
    function drawSource(m, k, viewProj) {
      gl.bindFramebuffer(gl.FRAMEBUFFER, targets[k].fb);
      gl.clearColor(0, 0, 0, 0);
      gl.clearDepth(1);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.enable(gl.DEPTH_TEST);
      gl.depthFunc(gl.LEQUAL);
      gl.useProgram(mesh);
      gl.uniformMatrix4fv(gl.getUniformLocation(mesh, "viewProj"), false, viewProj);
      gl.uniform4f(gl.getUniformLocation(mesh, "probe"), m.position[0], m.position[1], m.position[2], m.cellAngle);
      gl.activeTexture(gl.TEXTURE0);
      gl.bindTexture(gl.TEXTURE_CUBE_MAP, m.texture);
      gl.uniform1i(gl.getUniformLocation(mesh, "cube"), 0);
      gl.bindBuffer(gl.ARRAY_BUFFER, m.vertices);
      var at = gl.getAttribLocation(mesh, "p");
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, 3, gl.FLOAT, false, 0, 0);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, m.elements);
      gl.drawElements(gl.TRIANGLES, m.count, gl.UNSIGNED_INT, 0);
    }
    function drawBlend(t, tolerance, near, far) {
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.disable(gl.DEPTH_TEST);
      gl.useProgram(blend);
      ["a", "b", "da", "db"].forEach(function (name, unit) {
        gl.activeTexture(gl.TEXTURE0 + unit);
        gl.bindTexture(gl.TEXTURE_2D, unit < 2 ? targets[unit].colour : targets[unit - 2].depth);
        gl.uniform1i(gl.getUniformLocation(blend, name), unit);
      });
      gl.uniform1f(gl.getUniformLocation(blend, "t"), t);
      gl.uniform1f(gl.getUniformLocation(blend, "tol"), tolerance);
      gl.uniform1f(gl.getUniformLocation(blend, "near"), near);
      gl.uniform1f(gl.getUniformLocation(blend, "far"), far);
      gl.bindBuffer(gl.ARRAY_BUFFER, quad);
      var at = gl.getAttribLocation(blend, "p");
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, 2, gl.FLOAT, false, 0, 0);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    }
    transition.played = Promise.all(link.glide.sources.map(function (s) {
      if (!all[s[0]]) return Promise.reject(new Error("no glide source " + s[0]));
      return loadSource(gl, all[s[0]], base);
    })).then(function (meshes) {
      var legs = link.glide.sources.map(function (s, i) { return { mesh: meshes[i], at: s[1] }; });
      var elapsed = clock(link.duration);
      return new Promise(function (resolve) {
        function draw(t) {
          var s = smoothstep(t);
          var resized = fit(canvas), w = canvas.width, h = canvas.height;
          if (!targets || resized) targets = [target(gl, w, h), target(gl, w, h)];
          gl.viewport(0, 0, w, h);
          // The leg the camera is on: the sources on either side of it.
          var k = 0;
          while (k < legs.length - 2 && legs[k + 1].at <= s) k++;
          var a = legs[k].mesh, b = legs[k + 1].mesh;
          var eye = along(link.glide.polyline, s);
          var near = 0.5 * Math.max(Math.min(a.nearest, b.nearest), 1e-6);
          var far = FAR * Math.max(all[link.glide.sources[k][0]].far, all[link.glide.sources[k + 1][0]].far);
          var yaw = from.yaw + wrap(to.yaw - from.yaw) * s, pitch = from.pitch + (to.pitch - from.pitch) * s;
          var viewProj = viewProjection(eye, yaw, pitch, from.fov, w / h, near, far);
          drawSource(a, 0, viewProj);
          drawSource(b, 1, viewProj);
          var da = distance(eye, a.position), db = distance(eye, b.position);
          var tolerance = TOLERANCE + 2 * Math.max(a.cellAngle, b.cellAngle);
          drawBlend(da + db > 0 ? da / (da + db) : 0, tolerance, near, far);
          transition.frames += 1;
          canvas.style.opacity = "1";
        }
        function frame(now) {
          if (closed) return resolve(false);
          var t = elapsed(now);
          draw(t);
          if (t >= 1) {
            transition.finished = true;
            return resolve(true);
          }
          requestAnimationFrame(frame);
        }
        requestAnimationFrame(frame);
      });
    }).catch(function (e) {
      transition.error = String(e && e.message || e);
      transition.close();
      return false;
    });
    return transition;
  }

  // A transition's clock: the fraction of `duration` seconds (at least a
  // tenth) passed since the first frame's time, at most 1.
  function clock(duration) {
    var begun = null;
    duration = Math.max(duration || 0, 0.1);
    return function (now) {
      if (begun === null) begun = now;
      return Math.min((now - begun) / 1000 / duration, 1);
    };
  }

  // Sizes the canvas to its box in device pixels; true if it changed.
  function fit(canvas) {
    var w = Math.max(1, Math.round(canvas.clientWidth * (window.devicePixelRatio || 1)));
    var h = Math.max(1, Math.round(canvas.clientHeight * (window.devicePixelRatio || 1)));
    if (canvas.width === w && canvas.height === h) return false;
    canvas.width = w;
    canvas.height = h;
    return true;
  }

  function overlay(container, canvas) {
    canvas.className = "exploremaps-transition";
    canvas.style.cssText = "position:absolute;left:0;top:0;width:100%;height:100%;z-index:1000;opacity:0;transition:opacity 0.2s;pointer-events:none";
    if (getComputedStyle(container).position === "static") container.style.position = "relative";
    container.appendChild(canvas);
  }

  // Starts a transition over `container` and returns it, or null when this
  // browser cannot show one (no WebGL, or the path has neither video nor
  // glide): the viewer then uses its own. `link`: the tour's link (its
  // video, reversed, duration (s), glide); `base`: the tour folder's URL
  // from the page; `from`: {yaw, pitch, fov} at the click; `to`: {yaw,
  // pitch} on arrival. `transition.kind` is "video" or "glide";
  // `transition.played` resolves true once the last frame is on screen
  // (false if it failed; the overlay is then gone); `close()` fades the
  // overlay out once the viewer shows the destination.
  function start(container, link, from, to, base) {
    base = base || "";
    if (!link.video && link.glide && window.WebGL2RenderingContext) return startGlide(container, link, from, to, base);
    if (!link.video || !window.WebGLRenderingContext) return null;
    var canvas = document.createElement("canvas");
    var gl = canvas.getContext("webgl", { alpha: false, antialias: false });
    var prog = gl && linked(gl, VERTEX, FRAGMENT);
    if (!prog) return null;
    overlay(container, canvas);

    var video = document.createElement("video");
    video.muted = true;
    video.playsInline = true;
    video.setAttribute("playsinline", "");
    video.preload = "auto";
    video.crossOrigin = "anonymous";
    video.src = base + link.video;

    gl.useProgram(prog);
    var buffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    var at = gl.getAttribLocation(prog, "p");
    gl.enableVertexAttribArray(at);
    gl.vertexAttribPointer(at, 2, gl.FLOAT, false, 0, 0);
    var texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    var uniform = function (name) { return gl.getUniformLocation(prog, name); };

    var transition = { canvas: canvas, video: video, kind: "video", frames: 0 };
    var closed = false;
    transition.close = function () {
      if (closed) return;
      closed = true;
      canvas.style.opacity = "0";
      setTimeout(function () {
        video.removeAttribute("src");
        video.load();
        if (canvas.parentNode) canvas.parentNode.removeChild(canvas);
      }, 250);
    };
    transition.played = new Promise(function (resolve) {
      var elapsed = clock(link.duration);
      function draw(t) {
        var s = smoothstep(t);
        fit(canvas);
        var w = canvas.width, h = canvas.height;
        gl.viewport(0, 0, w, h);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGB, gl.RGB, gl.UNSIGNED_BYTE, video);
        gl.uniform1f(uniform("yaw"), from.yaw + wrap(to.yaw - from.yaw) * s);
        gl.uniform1f(uniform("pitch"), from.pitch + (to.pitch - from.pitch) * s);
        gl.uniform1f(uniform("tanHalf"), Math.tan(from.fov / 2));
        gl.uniform1f(uniform("aspect"), w / h);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
        transition.frames += 1;
        canvas.style.opacity = "1";
      }
      function frame(now) {
        if (closed) return resolve(false);
        var t = elapsed(now);
        // Forward the video plays on its own clock; reversed it is sought
        // frame by frame (its frames are all key frames or P-frames).
        if (link.reversed) {
          if (!video.seeking) {
            draw(t);
            video.currentTime = (1 - t) * video.duration;
          }
        } else {
          t = Math.min(video.currentTime / video.duration, 1);
          draw(t);
        }
        if (t >= 1 || (!link.reversed && video.ended)) {
          draw(1);
          transition.finished = true;
          return resolve(true);
        }
        requestAnimationFrame(frame);
      }
      video.addEventListener("error", function () {
        transition.close();
        resolve(false);
      });
      video.addEventListener("loadeddata", function () {
        if (link.reversed) {
          video.currentTime = video.duration;
          requestAnimationFrame(frame);
        } else {
          video.play().then(function () { requestAnimationFrame(frame); }, function () {
            transition.close();
            resolve(false);
          });
        }
      }, { once: true });
    });
    return transition;
  }

  window.ExploreMapsTransition = { start: start, smoothstep: smoothstep };
})();
