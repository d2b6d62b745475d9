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
// shown to a window ahead of it. The closed loop carries state from frame
// 0, so looping and seeking back decode again from the start of the bytes
// held (Player.rewind); the file is fetched once.
//
// Also: "cgv-status" (detail: stats), "cgv-error" (detail: message),
// "cgv-frame" (detail: the frame shown) and "cgv-camera" (detail: camera
// state), the last two for synchronizing views.

import init, { Player, View } from './pkg/cgv.js';

let ready = null;
/** Loads the wasm module once per page. */
export function loadWasm(url) {
  if (!ready) ready = init(url ? { module_or_path: url } : undefined);
  return ready;
}

/** The WebCodecs codec string of the SPS in an Annex-B access unit. */
export function codecString(au) {
  for (let i = 0; i + 4 < au.length; i++) {
    if (au[i] === 0 && au[i + 1] === 0 && au[i + 2] === 1 && (au[i + 3] & 0x1f) === 7) {
      const hex = (b) => b.toString(16).padStart(2, '0');
      return `avc1.${hex(au[i + 4])}${hex(au[i + 5])}${hex(au[i + 6])}`;
    }
  }
  return 'avc1.42001f';
}

/** Whether an access unit holds an IDR picture (a key frame for WebCodecs). */
export function isKey(au) {
  for (let i = 0; i + 3 < au.length; i++) {
    if (au[i] === 0 && au[i + 1] === 0 && au[i + 2] === 1 && (au[i + 3] & 0x1f) === 5) return true;
  }
  return false;
}

/** One H.264 stream through WebCodecs, picture by picture, luma only. */
export class LumaDecoder {
  constructor(size) {
    this.size = size;
    this.waiting = [];
    this.ready = [];
    this.error = null;
    this.decoder = null;
  }
  async decode(au, timestamp) {
    if (!this.decoder) {
      this.decoder = new VideoDecoder({
        output: (frame) => this._output(frame),
        error: (e) => { this.error = e; this.waiting.splice(0).forEach((w) => w.reject(e)); },
      });
      const config = { codec: codecString(au), optimizeForLatency: true };
      const support = await VideoDecoder.isConfigSupported(config);
      if (!support.supported) throw new Error(`this browser cannot decode ${config.codec} with WebCodecs`);
      this.decoder.configure(config);
    }
    if (this.error) throw this.error;
    const got = new Promise((resolve, reject) => this.waiting.push({ resolve, reject }));
    this.decoder.decode(new EncodedVideoChunk({ type: isKey(au) ? 'key' : 'delta', timestamp, data: au }));
    return got;
  }
  async _output(frame) {
    try {
      // The coded size can exceed the picture (64x66 for 64x64): take the visible rect.
      const n = this.size;
      const rect = { x: frame.visibleRect.x, y: frame.visibleRect.y, width: n, height: n };
      const buf = new Uint8Array(frame.allocationSize({ rect }));
      const layout = await frame.copyTo(buf, { rect });
      const y = layout[0];
      const luma = new Uint8Array(n * n);
      for (let r = 0; r < n; r++) luma.set(buf.subarray(y.offset + r * y.stride, y.offset + r * y.stride + n), r * n);
      const w = this.waiting.shift();
      if (w) w.resolve(luma);
    } catch (e) {
      const w = this.waiting.shift();
      if (w) w.reject(e);
    } finally {
      frame.close();
    }
  }
  close() {
    if (this.decoder && this.decoder.state !== 'closed') this.decoder.close();
  }
}

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
  static get observedAttributes() { return ['src', 'mode', 'poster']; }

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
    this.frames = [];
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
  set loop(on) { this.toggleAttribute('loop', !!on); this.$('.loop').checked = !!on; }
  get autoplay() { return this.hasAttribute('autoplay'); }
  set autoplay(on) { this.toggleAttribute('autoplay', !!on); }
  get src() { return this.getAttribute('src') || ''; }
  set src(v) { this.setAttribute('src', v); }
  /** Frames held in memory now (decoded, not yet dropped). */
  get bufferedFrames() { return this.held || 0; }

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
    this.frames = [];
    this.held = 0;
    this.seekTo = null;
    this.rewindWanted = false;
    this.header = null;
    this.shown = null;
    this.texture = undefined;
    this.view?.reframe();
    this.current = 0;
    this.stats.decoded = 0;
    this.stats.firstFrameMs = null;
    this.t0 = performance.now();
    this.message('loading…');
    try {
      if (typeof VideoDecoder === 'undefined') {
        throw new Error('This browser has no WebCodecs VideoDecoder, which the viewer needs to decode H.264. Try a recent Chrome, Edge or Safari.');
      }
      await loadWasm();
      this.player = new Player('');
      this.decoders?.forEach((d) => d.close());
      this.decoders = null;
      const feed = async (bytes) => {
        this.player.push(bytes);
        this._header(gen);
        this.dispatchEvent(new Event('progress'));
        this._pump(gen);
      };
      if (typeof source === 'string') {
        const resp = await fetch(source);
        if (!resp.ok) throw new Error(`${source}: HTTP ${resp.status}`);
        const reader = resp.body.getReader();
        for (;;) {
          const { done, value } = await reader.read();
          if (gen !== this.generation) return;
          if (done) break;
          await feed(value);
        }
      } else {
        const buf = source instanceof ArrayBuffer ? source : await source.arrayBuffer();
        await feed(new Uint8Array(buf));
      }
      if (!this.player.is_complete()) throw new Error('the file ended early (truncated)');
    } catch (e) {
      if (gen === this.generation) this.message(`Cannot play this file: ${e.message || e}`, true);
    }
  }

  _header(gen) {
    if (this.header || gen !== this.generation || !this.player.header_json()) return;
    const h = JSON.parse(this.player.header_json());
    this.header = h;
    // Frames held ahead of the one shown, and whether the motion is long
    // enough that the rest are dropped (else every frame is kept).
    const seconds = +(this.getAttribute('buffer') || 3);
    this.window = Math.max(8, Math.ceil((seconds > 0 ? seconds : 3) * h.fps));
    this.bounded = h.frames > 2 * this.window + 4;
    this.dispatchEvent(new Event('loadedmetadata'));
  }

  /** How far frame k lies ahead of the one shown (around the loop). */
  _ahead(k) {
    const n = this.header.frames;
    return k >= this.current ? k - this.current : k + n - this.current;
  }

  /** Whether the pump should decode frame k now, and keep it. */
  _wants(k) {
    if (!this.bounded) return { go: true, keep: true };
    const seeking = this.seekTo !== null && k < this.seekTo;
    const d = this._ahead(k);
    return { go: seeking || d <= this.window, keep: !seeking && d <= this.window };
  }

  /** Drops the frames outside [shown - 2, shown + window] (a long motion only). */
  _evict() {
    if (!this.bounded) return;
    const n = this.header.frames;
    for (const key in this.frames) {
      const k = +key, behind = (this.current - k + n) % n;
      if (behind > 2 && this._ahead(k) > this.window) { delete this.frames[k]; this.held--; }
    }
  }

  /** Starts decoding from frame 0 again (a loop, or a seek back). */
  _rewind(h) {
    this.decoders?.forEach((d) => d.close());
    this.decoders = h.streams.map((s) => new LumaDecoder(h.grid >> (s.shrink || 0)));
    this.player.rewind();
    this.rewindWanted = false;
  }

  /** Shows frame f, decoding from the start of the bytes held if it is not here (a seek). */
  seekFrame(f) {
    if (!this.header) return;
    const n = this.header.frames;
    f = Math.max(0, Math.min(Math.round(f), n - 1));
    this.dispatchEvent(new Event('seeking'));
    if (this.frames[f]) { this.show(f); this.dispatchEvent(new Event('seeked')); return; }
    this.current = f;
    this.seekTo = f;
    // Behind the decoder: decode again from 0 (ahead: decode on to it).
    if (this.player.next_frame() > f) this.rewindWanted = true;
    this._evict();
    this._pump(this.generation);
  }

  async _pump(gen) {
    if (this.pumping || gen !== this.generation) return;
    this.pumping = true;
    try {
      const h = JSON.parse(this.player.header_json() || 'null');
      if (!h) return;
      this.header = h;
      if (!this.view || this.viewGrid !== h.grid) {
        this._resize();
        this.view = await View.create(this.canvas, h.grid, this.hasAttribute('webgl'));
        this.shown = null;
        this.viewGrid = h.grid;
        this.stats.backend = this.view.backend();
      }
      // A stream may be coded on a coarser grid (format v9: `shrink` halvings).
      if (!this.decoders) this.decoders = h.streams.map((s) => new LumaDecoder(h.grid >> (s.shrink || 0)));
      if (h.appearance && this.texture === undefined && this.player.source_uvs().length) {
        this.texture = null;
        this._texture(h.appearance, gen);
      }
      this.$('.slider').max = h.frames - 1;
      this.stats.grid = h.grid;
      this.stats.frames = h.frames;
      for (;;) {
        if (gen !== this.generation) return;
        if (this.rewindWanted) this._rewind(h);
        let f = this.player.next_frame();
        if (f >= h.frames) {
          // The end of a lap: a long looping motion starts the next one.
          if (!(this.bounded && this.hasAttribute('loop'))) break;
          this._rewind(h);
          f = 0;
        }
        if (f >= this.player.complete_frames()) break;
        const want = this._wants(f);
        if (!want.go) break; // the window is full; show() wakes the pump
        const t = performance.now();
        const lumas = await Promise.all(h.streams.map((_, s) =>
          this.player.has_frame(s, f) ? this.decoders[s].decode(this.player.access_unit(s, f), f) : null));
        const t1 = performance.now();
        if (gen !== this.generation) return;
        lumas.forEach((l, s) => { if (l) this.player.supply_luma(s, l); });
        const x = this.player.decode_next();
        const t2 = performance.now();
        const k = this.stats.decoded;
        this.stats.decodeMs = (this.stats.decodeMs * k + (t1 - t)) / (k + 1);
        this.stats.reconstructMs = (this.stats.reconstructMs * k + (t2 - t1)) / (k + 1);
        this.stats.decoded = k + 1;
        if (want.keep && !this.frames[f]) { this.frames[f] = x; this.held++; }
        this.stats.kbps = this.player.bytes() * 8 / 1000 / (Math.max(1, this.player.complete_frames()) / h.fps);
        this.$('.progress').style.width = `${100 * this.player.complete_frames() / h.frames}%`;
        if (this.stats.firstFrameMs === null) {
          this.message('');
          this.show(0);
          this.stats.firstFrameMs = performance.now() - this.t0;
          this.$('.wrap').style.background = '';
          if (this.hasAttribute('autoplay')) this.play();
        }
        if (f === this.seekTo) {
          this.seekTo = null;
          this.show(f);
          this.dispatchEvent(new Event('seeked'));
        }
        this._status();
        // Let the page breathe between frames.
        await new Promise((r) => setTimeout(r, 0));
      }
      if (this.player.is_complete()) this.stats.kbps = this.player.bytes() * 8 / 1000 / (h.frames / h.fps);
    } catch (e) {
      if (gen === this.generation) this.message(`Cannot play this file: ${e.message || e}`, true);
    } finally {
      this.pumping = false;
    }
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
    this._evict();
    // Room in the window again: decode on.
    if (this.bounded && !this.pumping) this._pump(this.generation);
    try {
      // The error map measures against the same frame of a reference player
      // (el.reference = otherPlayer), e.g. GV against CGV of one motion.
      const ref = this.mode === 'error' ? this.reference?.frames?.[f] : undefined;
      const s = this.shown;
      // The input's own mesh (a version-6 file carries it) when shaded;
      // λ, H and the error map are the grid's. mesh="grid" keeps the grid.
      const sm = this.header?.source_mesh;
      const mesh = !!sm && this.mode === 'shaded' && this.getAttribute('mesh') !== 'grid';
      if (!s || s.frame !== this.frames[f] || s.mode !== this.mode || s.ref !== ref || s.mesh !== mesh) {
        if (!s || s.mesh !== mesh || s.texture !== this.texture) {
          this.view.set_mesh(mesh ? this.player.source_faces() : new Uint32Array(0), mesh ? sm.vertices : 0);
          const t = this.texture;
          if (mesh && t) this.view.set_texture(t.uvs, t.baseColor, t.rgba, t.width, t.height);
        }
        this.view.set_reference(ref || new Float32Array(0));
        this.view.set_frame(mesh ? this.player.source_vertices(this.frames[f]) : this.frames[f], this.mode);
        this.shown = { frame: this.frames[f], mode: this.mode, ref, mesh, texture: this.texture };
        this.dataset.textured = mesh && this.texture?.width > 0 ? 'yes' : 'no';
        this.dataset.surface = mesh ? 'source' : 'grid';
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
