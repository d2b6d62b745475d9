// <cgv-player src="motion.cgv" autoplay loop mode="shaded">: plays a .cgv
// file. The wasm core parses the file as it streams in and rebuilds each
// frame; H.264 is decoded here with WebCodecs; the shared wgpu renderer draws
// with WebGPU, or WebGL2 when the browser has no WebGPU adapter.
//
// It behaves like <video> where that makes sense: currentTime (settable: a
// seek), duration, paused, play() (a promise), pause(), playbackRate, loop,
// autoplay, poster, loading="lazy"; events loadedmetadata, progress, play,
// pause, timeupdate, seeking, seeked, ended, error. Keyboard (the element
// takes focus): space or k plays and pauses, arrows step a frame (with
// shift, a second), Home and End go to the ends.
//
// Memory is bounded: a motion longer than twice the decode-ahead window
// (buffer="3", seconds) keeps only the frames from just behind the one
// shown to a window ahead of it. The closed loop carries state from the
// last random-access point (format v10: every 2 s by default), so a seek
// decodes again from the point before its frame, from the bytes held
// (Player.seek; frame 0 in older files); the file is fetched once.
//
// Also: "cgv-status" (detail: stats), "cgv-error" (detail: message),
// "cgv-frame" (detail: the frame shown) and "cgv-camera" (detail: camera
// state), the last two for synchronizing views.

import { View } from './pkg/cgv.js';
import { MotionStream, loadWasm, usePackage } from './cgv-stream.js';

// The element draws with the full package's View: its streams decode with
// the same instance (a three.js module on the page gives way to it).
usePackage(new URL('./pkg/cgv.js', import.meta.url).href);

// What pages imported from here before the pipeline had its own module.
export { loadWasm, codecString, isKey, LumaDecoder } from './cgv-stream.js';

const STYLE = `
:host { display: block; position: relative; background: #12141a; color: #ddd; font: 13px system-ui, sans-serif; min-height: 200px; }
canvas { width: 100%; height: 100%; display: block; touch-action: none; }
.wrap { position: relative; width: 100%; height: calc(100% - 44px); min-height: 160px; }
.bar { display: flex; gap: 6px; align-items: center; padding: 6px; height: 32px; flex-wrap: nowrap; }
.bar input[type=range] { flex: 1; min-width: 60px; }
button, select { background: #2a2e38; color: #eee; border: 1px solid #444; border-radius: 4px; padding: 3px 8px; }
.stats { position: absolute; top: 6px; left: 6px; background: #000a; padding: 4px 6px; border-radius: 4px; white-space: pre; font: 11px ui-monospace, monospace; pointer-events: none; }
.msg { position: absolute; inset: 0; display: none; align-items: center; justify-content: center; text-align: center; padding: 20px; background: #12141aee; }
.msg.on { display: flex; }
.msg.error { color: #ff8a80; }
.progress { position: absolute; left: 0; bottom: 0; height: 3px; background: #4caf50; width: 0; transition: width .2s; }
`;

export class CgvPlayer extends HTMLElement {
  static get observedAttributes() { return ['src', 'mode', 'poster', 'loop']; }

  constructor() {
    super();
    const root = this.attachShadow({ mode: 'open' });
    root.innerHTML = `<style>${STYLE}</style>
      <div class="wrap"><canvas></canvas><div class="stats"></div><div class="progress"></div><div class="msg"></div></div>
      <div class="bar">
        <button class="play" title="play / pause" aria-label="play">▶</button>
        <input class="slider" type="range" min="0" max="0" value="0" title="frame" aria-label="frame">
        <span class="counter" aria-live="off">0 / 0</span>
        <select class="speed" title="speed" aria-label="playback speed"><option value="0.25">¼×</option><option value="0.5">½×</option><option value="1" selected>1×</option><option value="2">2×</option></select>
        <label title="loop"><input class="loop" type="checkbox" aria-label="loop"> loop</label>
        <select class="mode" title="colour" aria-label="colour"><option>shaded</option><option value="lambda">λ</option><option value="h">H</option><option>error</option></select>
      </div>`;
    this.$ = (s) => root.querySelector(s);
    this.canvas = this.$('canvas');
    this.playing = false;
    this.current = 0;
    this.generation = 0;
    this.stats = { backend: '–', fps: 0, decodeMs: 0, reconstructMs: 0, kbps: 0, grid: 0, frames: 0, decoded: 0, firstFrameMs: null };
    this.rate = 1;
    this.$('.play').onclick = () => (this.playing ? this.pause() : this.play());
    this.$('.slider').oninput = (e) => { this.pause(); this.seekFrame(+e.target.value); };
    this.$('.speed').onchange = (e) => { this.rate = +e.target.value; };
    this.addEventListener('keydown', (e) => this._key(e));
    this.$('.loop').onchange = (e) => this.toggleAttribute('loop', e.target.checked);
    this.$('.mode').onchange = (e) => this.setAttribute('mode', e.target.value);
    this._pointers();
  }

  connectedCallback() {
    if (!this.hasAttribute('tabindex')) this.tabIndex = 0;
    this.$('.loop').checked = this.hasAttribute('loop');
    if (this.getAttribute('mode')) this.$('.mode').value = this.getAttribute('mode');
    new ResizeObserver(() => this._resize()).observe(this.canvas);
  }

  attributeChangedCallback(name, _old, value) {
    if (name === 'loop') {
      this.$('.loop').checked = value !== null;
      if (this.stream) { this.stream.loop = value !== null; this.stream.pump(); }
    }
    if (name === 'src' && value) this._loadWhenVisible(value);
    if (name === 'poster') this.$('.wrap').style.background = value ? `center / contain no-repeat url("${value}")` : '';
    if (name === 'mode') { this.$('.mode').value = value; this.show(this.current); }
  }

  get mode() { return this.getAttribute('mode') || 'shaded'; }

  message(text, isError) {
    const m = this.$('.msg');
    m.textContent = text || '';
    m.className = 'msg' + (text ? ' on' : '') + (isError ? ' error' : '');
    if (isError) {
      this.dispatchEvent(new CustomEvent('cgv-error', { detail: text, bubbles: true }));
      this.dispatchEvent(new Event('error'));
    }
  }

  // --- what <video> offers ---
  get duration() { return this.header ? this.header.frames / this.header.fps : NaN; }
  get currentTime() { return this.header ? this.current / this.header.fps : 0; }
  set currentTime(t) { if (this.header) this.seekFrame(Math.floor(t * this.header.fps + 1e-6)); }
  get paused() { return !this.playing; }
  get playbackRate() { return this.rate; }
  set playbackRate(r) {
    this.rate = +r > 0 ? +r : 1;
    const o = [...this.$('.speed').options].find((x) => +x.value === this.rate);
    if (o) this.$('.speed').value = o.value;
  }
  get loop() { return this.hasAttribute('loop'); }
  set loop(on) { this.toggleAttribute('loop', !!on); }
  get autoplay() { return this.hasAttribute('autoplay'); }
  set autoplay(on) { this.toggleAttribute('autoplay', !!on); }
  get src() { return this.getAttribute('src') || ''; }
  set src(v) { this.setAttribute('src', v); }
  /** Frames held in memory now (decoded, not yet dropped). */
  get bufferedFrames() { return this.stream?.held || 0; }
  /** The decoded frames held (sparse: a long motion keeps a window). */
  get frames() { return this.stream?.frames || []; }
  /** The file's header, once it has arrived. */
  get header() { return this.stream?.header || null; }
  /** The wasm Player under the stream (the input's mesh, its texture). */
  get player() { return this.stream?.player; }

  /** loading="lazy": the file is fetched once the element nears the viewport. */
  _loadWhenVisible(src) {
    this.lazy?.disconnect();
    if (this.getAttribute('loading') !== 'lazy' || typeof IntersectionObserver === 'undefined') return this.load(src);
    this.lazy = new IntersectionObserver((entries) => {
      if (entries.some((e) => e.isIntersecting)) { this.lazy.disconnect(); this.lazy = null; this.load(src); }
    }, { rootMargin: '200px' });
    this.lazy.observe(this);
  }

  _key(e) {
    if (!this.header || e.target !== this) return;
    const n = this.header.frames, step = e.shiftKey ? Math.round(this.header.fps) : 1;
    const go = { ArrowRight: this.current + step, ArrowLeft: this.current - step, Home: 0, End: n - 1 }[e.key];
    if (e.key === ' ' || e.key === 'k') this.playing ? this.pause() : this.play();
    else if (go !== undefined) { this.pause(); this.seekFrame(go); }
    else return;
    e.preventDefault();
  }

  /** Loads a URL (streamed), a File/Blob, or an ArrayBuffer. */
  async load(source) {
    const gen = ++this.generation;
    this.pause();
    this.stream?.close();
    const stream = new MotionStream({ buffer: +(this.getAttribute('buffer') || 3), loop: this.hasAttribute('loop') });
    this.stream = stream;
    this.shown = null;
    this.texture = undefined;
    this.view?.reframe();
    this.current = 0;
    this.stats.decoded = 0;
    this.stats.firstFrameMs = null;
    this.t0 = performance.now();
    this.message('loading…');
    const mine = (fn) => (e) => { if (gen === this.generation) fn(e); };
    const fail = (text) => this.message(`Cannot play this file: ${text}`, true);
    stream.addEventListener('loadedmetadata', mine(() => this._metadata(gen)));
    stream.addEventListener('progress', mine(() => {
      const h = stream.header;
      const part = stream.ranged ? stream.fetched / stream.total : h && stream.player.complete_frames() / h.frames;
      if (h) this.$('.progress').style.width = `${100 * part}%`;
      this.dispatchEvent(new Event('progress'));
    }));
    stream.addEventListener('frame', mine((e) => this._decoded(e.detail)));
    stream.addEventListener('seeked', mine((e) => { this.show(e.detail); this.dispatchEvent(new Event('seeked')); }));
    stream.addEventListener('error', mine((e) => fail(e.detail)));
    try {
      await stream.open(source);
    } catch (e) {
      if (gen === this.generation) fail(e.message || e);
    }
  }

  /** The header has arrived: the view for its grid, the controls, the texture. */
  async _metadata(gen) {
    const h = this.header;
    this.$('.slider').max = h.frames - 1;
    this.stats.grid = h.grid;
    this.stats.frames = h.frames;
    this.dispatchEvent(new Event('loadedmetadata'));
    try {
      if (!this.view || this.viewGrid !== h.grid) {
        this._resize();
        this.view = null;
        const view = await View.create(this.canvas, h.grid, this.hasAttribute('webgl'));
        if (gen !== this.generation) return;
        this.view = view;
        this.viewGrid = h.grid;
        this.stats.backend = view.backend();
      }
      this.shown = null;
      this._textureOnce(gen);
      if (this.frames[0]) this._decoded(0);
    } catch (e) {
      if (gen === this.generation) this.message(`Cannot draw: ${e.message || e}`, true);
    }
  }

  /** Starts decoding the texture once the appearance has arrived: with the
   * header when the first range holds it, else before the first frame. */
  _textureOnce(gen) {
    const h = this.header;
    if (h?.appearance && this.texture === undefined && this.player.source_uvs().length) {
      this.texture = null;
      this._texture(h.appearance, gen);
    }
  }

  /** Frame f was decoded: the first one is shown (and starts autoplay). */
  _decoded(f) {
    this._textureOnce(this.generation);
    const s = this.stream.stats;
    Object.assign(this.stats, { decodeMs: s.decodeMs, reconstructMs: s.reconstructMs, decoded: s.decoded, kbps: s.kbps });
    if (this.stats.firstFrameMs === null && this.view && this.frames[0]) {
      this.message('');
      this.show(0);
      this.stats.firstFrameMs = performance.now() - this.t0;
      this.$('.wrap').style.background = '';
      if (this.hasAttribute('autoplay')) this.play();
    }
    if (f % 8 === 0 || f === this.header.frames - 1) this._status();
  }

  /** Shows frame f, decoding up to it first if it is not held (a seek). */
  seekFrame(f) {
    if (!this.header) return;
    f = Math.max(0, Math.min(Math.round(f), this.header.frames - 1));
    this.dispatchEvent(new Event('seeking'));
    this.current = f;
    if (this.stream.seek(f)) { this.show(f); this.dispatchEvent(new Event('seeked')); }
  }

  /** Decodes the file's base colour texture (format v8) with the browser's
   * image decoder, then shows the current frame with it. */
  async _texture(look, gen) {
    const t = { uvs: this.player.source_uvs(), baseColor: new Float32Array(look.base_color), rgba: new Uint8Array(0), width: 0, height: 0 };
    try {
      if (look.texture) {
        const blob = new Blob([this.player.texture_bytes()], { type: look.texture.mime });
        const bitmap = await createImageBitmap(blob);
        const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
        const ctx = canvas.getContext('2d');
        ctx.drawImage(bitmap, 0, 0);
        t.rgba = new Uint8Array(ctx.getImageData(0, 0, bitmap.width, bitmap.height).data.buffer);
        [t.width, t.height] = [bitmap.width, bitmap.height];
      }
    } catch (e) {
      console.warn(`cgv-player: the texture could not be decoded (${e.message || e}); drawing the base colour`);
    }
    if (gen !== this.generation) return;
    this.texture = t;
    if (this.frames[this.current]) this.show(this.current);
  }

  /** Shows frame f. The view keeps the frame it was given: only a new
   * frame, colour mode or reference is handed to wasm again. */
  show(f) {
    if (!this.view || !this.header) return;
    f = Math.max(0, Math.min(f, this.header.frames - 1));
    if (!this.frames[f]) return;
    const moved = f !== this.current;
    this.current = f;
    // Frames behind may go; room in the window again: decoding goes on.
    this.stream.setCurrent(f);
    try {
      // The error map measures against the same frame of a reference player
      // (el.reference = otherPlayer), e.g. GV against CGV of one motion.
      const ref = this.mode === 'error' ? this.reference?.frames?.[f] : undefined;
      const s = this.shown;
      // The input's own mesh (a version-6 file carries it) when shaded;
      // λ, H and the error map are the grid's. mesh="grid" keeps the grid.
      const sm = this.header?.source_mesh;
      // A skinned file's grid (format v17) is what its bones miss, and a
      // file without streams (v20) has none: only its mesh is a surface,
      // shown shaded.
      const skinned = this.header?.skin?.rest_step != null || this.header?.streams?.length === 0;
      const mode = skinned ? 'shaded' : this.mode;
      const own = mode === 'shaded' && this.getAttribute('mesh') !== 'grid';
      // A capture's file (format v16) carries each frame's own mesh.
      const fm = own ? this.frames[f].mesh : undefined;
      const mesh = fm ? 'frame' : !!sm && (skinned || own) ? 'source' : 'grid';
      if (!s || s.frame !== this.frames[f] || s.mode !== this.mode || s.ref !== ref || s.mesh !== mesh) {
        if (!s || s.mesh !== mesh || s.texture !== this.texture || mesh === 'frame') {
          if (mesh === 'frame') this.view.set_mesh(fm.faces, fm.vertices.length / 3);
          else this.view.set_mesh(mesh === 'source' ? this.player.source_faces() : new Uint32Array(0), mesh === 'source' ? sm.vertices : 0);
          const t = this.texture;
          if (mesh === 'source' && t) this.view.set_texture(t.uvs, t.baseColor, t.rgba, t.width, t.height);
        }
        this.view.set_reference(ref || new Float32Array(0));
        const x = this.frames[f];
        this.view.set_frame(mesh === 'frame' ? fm.vertices : mesh === 'source' ? this.player.source_vertices(x, x.loose, x.skinned) : x, mode);
        this.shown = { frame: this.frames[f], mode: this.mode, ref, mesh, texture: this.texture };
        this.dataset.textured = mesh === 'source' && this.texture?.width > 0 ? 'yes' : 'no';
        this.dataset.surface = mesh;
        this.view.draw();
      }
    } catch (e) {
      this.message(`Cannot draw: ${e.message || e}`, true);
    }
    this.$('.slider').value = f;
    this.$('.counter').textContent = `${f + 1} / ${this.header ? this.header.frames : 0}`;
    this.dataset.frame = f;
    this.dispatchEvent(new CustomEvent('cgv-frame', { detail: f }));
    if (moved) this.dispatchEvent(new Event('timeupdate'));
  }

  /** Shows the frame at a shared clock time (seconds), for synchronized views. */
  seek(seconds) {
    if (!this.header) return;
    const n = this.header.frames;
    let f = Math.floor(seconds * this.header.fps);
    f = this.hasAttribute('loop') ? f % n : Math.min(f, n - 1);
    if (this.frames[f]) this.show(f);
  }

  /** Plays from the frame shown; resolves at once (as <video>'s play() does once it can play). */
  play() {
    if (this.playing || !this.header) return Promise.resolve();
    const n = this.header.frames;
    if (this.current >= n - 1 && !this.hasAttribute('loop')) this.seekFrame(0);
    this.playing = true;
    this.$('.play').textContent = '❚❚';
    this.$('.play').setAttribute('aria-label', 'pause');
    this.dispatchEvent(new Event('play'));
    let last = performance.now();
    let clock = this.current / this.header.fps;
    let drawn = 0, fpsStart = last;
    const tick = (now) => {
      if (!this.playing) return;
      const fps = this.header.fps;
      let next = clock + (now - last) / 1000 * this.rate;
      let f = Math.floor(next * fps);
      if (f >= n) {
        if (!this.hasAttribute('loop')) {
          this.show(n - 1);
          this.pause();
          this.dispatchEvent(new Event('ended'));
          return;
        }
        next -= n / fps;
        f = Math.max(0, f - n);
      }
      if (this.frames[f]) {
        clock = next;
        if (f !== this.current) { this.show(f); drawn++; }
      }
      // else: decoding is behind; hold the frame until it catches up.
      last = now;
      if (now - fpsStart > 1000) { this.stats.fps = drawn * 1000 / (now - fpsStart); drawn = 0; fpsStart = now; this._status(); }
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
    return Promise.resolve();
  }

  pause() {
    const was = this.playing;
    this.playing = false;
    this.$('.play').textContent = '▶';
    this.$('.play').setAttribute('aria-label', 'play');
    if (was) this.dispatchEvent(new Event('pause'));
  }

  _status() {
    const s = this.stats;
    this.$('.stats').textContent =
      `${s.backend} · ${s.fps.toFixed(0)} fps\n` +
      `decode ${s.decodeMs.toFixed(1)} ms · rebuild ${s.reconstructMs.toFixed(1)} ms /frame\n` +
      `${s.kbps.toFixed(0)} kbit/s · N=${s.grid} · ${Math.min(s.decoded, s.frames)}/${s.frames} frames`;
    this.dispatchEvent(new CustomEvent('cgv-status', { detail: { ...s, frame: this.current }, bubbles: true }));
  }

  _resize() {
    const r = this.canvas.getBoundingClientRect();
    const dpr = Math.min(window.devicePixelRatio || 1, 2);
    const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
      if (this.view) { this.view.resize(w, h); this._redraw(); }
    }
  }

  /** Camera state [target xyz, distance, yaw, pitch] and its setter, for syncing views. */
  get camera() { return this.view ? Array.from(this.view.camera_state()) : null; }
  set camera(s) { if (this.view && s) { this.view.set_camera_state(new Float32Array(s)); this._redraw(); } }

  /** Draws the frame the view holds again (a camera move or a resize: no new data). */
  _redraw() {
    try {
      if (this.shown) this.view.draw();
    } catch (e) {
      this.message(`Cannot draw: ${e.message || e}`, true);
    }
  }

  _cameraMoved() {
    this._redraw();
    this.dispatchEvent(new CustomEvent('cgv-camera', { detail: this.camera, bubbles: true }));
  }

  _pointers() {
    const c = this.canvas;
    const pts = new Map();
    let pinch = 0;
    c.addEventListener('pointerdown', (e) => { c.setPointerCapture(e.pointerId); pts.set(e.pointerId, [e.clientX, e.clientY]); });
    c.addEventListener('pointerup', (e) => { pts.delete(e.pointerId); pinch = 0; });
    c.addEventListener('pointercancel', (e) => { pts.delete(e.pointerId); pinch = 0; });
    c.addEventListener('pointermove', (e) => {
      if (!pts.has(e.pointerId) || !this.view) return;
      const [x0, y0] = pts.get(e.pointerId);
      pts.set(e.pointerId, [e.clientX, e.clientY]);
      if (pts.size === 2) {
        const [a, b] = [...pts.values()];
        const d = Math.hypot(a[0] - b[0], a[1] - b[1]);
        if (pinch) this.view.zoom(pinch / d);
        pinch = d;
      } else {
        const h = c.getBoundingClientRect().height || 1;
        this.view.drag((e.clientX - x0) / h, (e.clientY - y0) / h);
      }
      this._cameraMoved();
    });
    c.addEventListener('wheel', (e) => { e.preventDefault(); if (this.view) { this.view.zoom(Math.exp(e.deltaY * 0.001)); this._cameraMoved(); } }, { passive: false });
    c.addEventListener('dblclick', () => { if (this.view) { this.view.reset(); this._cameraMoved(); } });
  }
}

customElements.define('cgv-player', CgvPlayer);
