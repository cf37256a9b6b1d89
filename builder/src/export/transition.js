// ExploreMaps transitions for tour viewers: plays a path's 360° video
// (equirectangular frames in world orientation, column 0 at yaw 0, row 0
// straight up) over the viewer, in perspective, turning from the view the
// visitor had to the arrival direction as ExploreMaps' own viewer does.
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

  function program(gl) {
    function shader(type, source) {
      var s = gl.createShader(type);
      gl.shaderSource(s, source);
      gl.compileShader(s);
      return s;
    }
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, FRAGMENT));
    gl.linkProgram(p);
    return gl.getProgramParameter(p, gl.LINK_STATUS) ? p : null;
  }

  // Starts a transition over `container` and returns it, or null when this
  // browser cannot play one (no WebGL or no video): the viewer then uses
  // its own. `link`: {video (URL), reversed, duration (s)}; `from`:
  // {yaw, pitch, fov} at the click; `to`: {yaw, pitch} on arrival.
  // `transition.played` resolves true once the last frame is on screen
  // (false if the video failed; the overlay is then gone); `close()` fades
  // the overlay out once the viewer shows the destination.
  function start(container, link, from, to) {
    if (!link.video || !window.WebGLRenderingContext) return null;
    var canvas = document.createElement("canvas");
    var gl = canvas.getContext("webgl", { alpha: false, antialias: false });
    var prog = gl && program(gl);
    if (!prog) return null;
    canvas.className = "exploremaps-transition";
    canvas.style.cssText = "position:absolute;left:0;top:0;width:100%;height:100%;z-index:1000;opacity:0;transition:opacity 0.2s;pointer-events:none";
    if (getComputedStyle(container).position === "static") container.style.position = "relative";
    container.appendChild(canvas);

    var video = document.createElement("video");
    video.muted = true;
    video.playsInline = true;
    video.setAttribute("playsinline", "");
    video.preload = "auto";
    video.crossOrigin = "anonymous";
    video.src = link.video;

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

    var transition = { canvas: canvas, video: video, frames: 0 };
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
      var duration = Math.max(link.duration || 0, 0.1);
      var begun = null;
      function draw(t) {
        var s = smoothstep(t);
        var w = Math.max(1, Math.round(canvas.clientWidth * (window.devicePixelRatio || 1)));
        var h = Math.max(1, Math.round(canvas.clientHeight * (window.devicePixelRatio || 1)));
        if (canvas.width !== w || canvas.height !== h) {
          canvas.width = w;
          canvas.height = h;
        }
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
        if (begun === null) begun = now;
        var t = Math.min((now - begun) / 1000 / duration, 1);
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
