// The decode pipeline under <cgv-player> and the three.js module, without
// any drawing: a .cgv file streamed in, its H.264 access units decoded with
// WebCodecs, each frame rebuilt by the wasm core, and a bounded window of
// decoded frames kept.
//
// A motion longer than twice the decode-ahead window (buffer seconds)
// keeps only the frames from two behind the one shown (`current`) to the
// window ahead of it; a shorter one keeps them all. The closed loop carries
// state from the last random-access point (format v10: one every 2 s by
// default; before v10 frame 0 only), so a seek restarts the decoder at the
// point before the frame it wants and decodes forward from the bytes held;
// the file is fetched once.
//
// From a server that answers HTTP range requests (cgv serve does), a
// version-10 file is fetched in pieces: its first bytes (header, source
// mesh), its index from the tail, then only the random-access points'
// stretches that playback and seeks need, a few seconds ahead; a seek to a
// point not fetched yet fetches that point first. Elsewhere (a server that
// answers 200, an older file, a Blob) the file streams in whole.
//
// Events: loadedmetadata (the header is here), progress (bytes came),
// frame (detail: a frame just decoded and kept), seeked (detail: the
// frame a seek asked for, now held), error (detail: the message).

// Which wasm package: ./pkg/ (decoder and renderer, what <cgv-player>
// draws with) unless a page that draws itself asks for ./pkg-decoder/ (the
// decoder alone, a smaller first download) with usePackage before loading.
let packageUrl = new URL('./pkg/cgv.js', import.meta.url).href;
let wasm = null;
let ready = null;

let pinned = false;

/** Makes streams load the wasm package at `url` (a module URL) instead of
 * ./pkg/; false (and no change) once a package is loaded. A `weak` choice
 * (the three.js module's) gives way to a plain one (<cgv-player>'s, which
 * needs the renderer), whichever comes first. */
export function usePackage(url, { weak = false } = {}) {
  if (ready || (weak && pinned)) return false;
  packageUrl = url;
  pinned = !weak;
  return true;
}

/** Loads the wasm package once per page; resolves to its exports. */
export function loadWasm(url) {
  if (!ready) {
    ready = import(packageUrl).then((m) => {
      wasm = m;
      return m.default(url ? { module_or_path: url } : undefined);
    });
  }
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

export class MotionStream extends EventTarget {
  /** The first request's size: the header and source mesh of most files. */
  static prefixBytes = 65536;

  /** buffer: seconds decoded ahead; loop: whether a long motion's decoder starts over at its end. */
  constructor({ buffer = 3, loop = false } = {}) {
    super();
    this.buffer = buffer > 0 ? buffer : 3;
    this.loop = loop;
    this.frames = [];
    this.held = 0;
    this.current = 0;
    this.seekTo = null;
    this.restartAt = null;
    this.header = null;
    this.player = null;
    this.decoders = null;
    this.closed = false;
    this.pumping = false;
    this.stats = { decodeMs: 0, reconstructMs: 0, decoded: 0, kbps: 0 };
    // Range requests: whether they are used, the file's size, the points
    // fetched, and the bytes fetched in all.
    this.ranged = false;
    this.total = 0;
    this.fetchedPoints = new Set();
    this.fetched = 0;
    this.filling = false;
  }

  /** Streams a URL, a Blob or an ArrayBuffer in; resolves once every byte has arrived. */
  async open(source) {
    if (typeof VideoDecoder === 'undefined') {
      throw new Error('This browser has no WebCodecs VideoDecoder, which the viewer needs to decode H.264. Try a recent Chrome, Edge or Safari.');
    }
    await loadWasm();
    this.player = new wasm.Player('');
    const feed = (bytes) => {
      this.player.push(bytes);
      this._metadata();
      this.dispatchEvent(new Event('progress'));
      this.pump();
    };
    if (typeof source === 'string') {
      // The first bytes by a range request: a server that honours it
      // answers 206 (and the file's size); one that does not sends it all.
      let resp = await fetch(source, { headers: { Range: `bytes=0-${MotionStream.prefixBytes - 1}` } });
      if (!resp.ok) throw new Error(`${source}: HTTP ${resp.status}`);
      const size = /\/(\d+)$/.exec(resp.headers.get('Content-Range') || '');
      if (resp.status === 206 && size) {
        await this._openRanged(source, +size[1], new Uint8Array(await resp.arrayBuffer()), feed);
        return;
      }
      if (resp.status === 206) {
        // A part whose whole size we cannot read (a cross-origin server
        // that does not expose Content-Range): ask for the whole file.
        resp = await fetch(source);
        if (!resp.ok) throw new Error(`${source}: HTTP ${resp.status}`);
      }
      if (!(await this._stream(resp, feed))) return;
    } else {
      const buf = new Uint8Array(source instanceof ArrayBuffer ? source : await source.arrayBuffer());
      this.fetched += buf.length;
      feed(buf);
    }
    if (!this.player.is_complete()) throw new Error('the file ended early (truncated)');
  }

  /** Feeds a response's body as it arrives; false if the stream closed meanwhile. */
  async _stream(resp, feed) {
    const reader = resp.body.getReader();
    for (;;) {
      const { done, value } = await reader.read();
      if (this.closed) return false;
      if (done) return true;
      this.fetched += value.length;
      feed(value);
    }
  }

  /** Bytes [a, b) of the file, by a range request. */
  async _range(a, b) {
    const resp = await fetch(this.url, { headers: { Range: `bytes=${a}-${b - 1}` } });
    if (resp.status !== 206) throw new Error(`${this.url}: asked for bytes ${a}-${b - 1}, got HTTP ${resp.status}`);
    const bytes = new Uint8Array(await resp.arrayBuffer());
    if (bytes.length !== b - a) throw new Error(`${this.url}: asked for ${b - a} bytes, got ${bytes.length}`);
    this.fetched += bytes.length;
    return bytes;
  }

  /** A file from a server that answers range requests (total bytes, the
   * first ones already here): the rest of the header if it is long, then
   * for a version-10 file the index from the tail and the stretch of the
   * first point, and the rest as playback asks (_fill); else the rest whole. */
  async _openRanged(url, total, first, feed) {
    this.url = url;
    this.total = total;
    this.fetched += first.length;
    feed(first);
    let got = first.length;
    if (!this.header && got >= 16) {
      // A header longer than the first request (its length is at byte 12).
      const end = 20 + new DataView(first.buffer, first.byteOffset).getUint32(12, true);
      const b = Math.min(total, end + MotionStream.prefixBytes);
      feed(await this._range(got, b));
      got = b;
    }
    if (!this.header) throw new Error(`${url}: no .cgv header in its first ${got} bytes`);
    const h = this.header;
    const tail = this.player.index_tail_bytes();
    if (!h.random_access || total <= got + tail) {
      // No points (an older file, a short motion): the rest, streamed.
      if (got < total) {
        const resp = await fetch(url, { headers: { Range: `bytes=${got}-` } });
        if (resp.status !== 206) throw new Error(`${url}: asked for bytes ${got}-, got HTTP ${resp.status}`);
        if (!(await this._stream(resp, feed))) return;
      }
      if (!this.player.is_complete()) throw new Error('the file ended early (truncated)');
      return;
    }
    const index = await this._range(total - tail, total);
    if (this.closed) return;
    this.player.set_index(index);
    this.ranged = true;
    // The point whose stretch the first bytes reached into, up to its end.
    let k = 0;
    for (;;) {
      const [, b] = this.player.point_bytes(k, total);
      if (b > got) {
        feed(await this._range(got, b));
        break;
      }
      this.fetchedPoints.add(k++);
    }
    this.fetchedPoints.add(k);
    this._fill();
  }

  /** The next point to fetch: the first not fetched among those from the
   * frame wanted (a seek's, else the one shown) to a window past it. */
  _nextPoint() {
    const h = this.header, K = h.random_access;
    const from = this.seekTo ?? this.current;
    // Points lie every K frames, and (format version 15) where segments
    // start: there every frame of the window is asked for its point.
    const segments = h.segments && h.segments.length > 0;
    const horizon = (this.window || 8) + (segments ? 0 : K), step = segments ? 1 : K;
    for (let d = 0; d <= horizon; d += step) {
      let f = from + d;
      // Looping, the window may wrap more than once on a motion shorter
      // than it (8 frames against a window of 8 + K).
      if (f >= h.frames) { if (!this.loop) break; f %= h.frames; }
      const k = this.player.point_of(f);
      if (!this.fetchedPoints.has(k)) return k;
    }
    return null;
  }

  /** Fetches points (_nextPoint) one at a time while any is wanted. */
  async _fill() {
    if (!this.ranged || this.filling || this.closed) return;
    this.filling = true;
    try {
      for (let k = this._nextPoint(); k !== null && !this.closed; k = this._nextPoint()) {
        const range = this.player.point_bytes(k, this.total);
        if (range.length !== 2) throw new Error(`${this.url}: no random-access point ${k} in the index`);
        const [a, b] = range;
        const bytes = await this._range(a, b);
        if (this.closed) return;
        if (this.player.bytes() !== a) this.player.jump(k);
        this.player.push(bytes);
        this.fetchedPoints.add(k);
        this.dispatchEvent(new Event('progress'));
        this.pump();
      }
    } catch (e) {
      if (!this.closed) this.dispatchEvent(new CustomEvent('error', { detail: e.message || String(e) }));
    } finally {
      this.filling = false;
    }
  }

  close() {
    this.closed = true;
    this.decoders?.forEach((d) => d.close());
  }

  _metadata() {
    if (this.header || !this.player.header_json()) return;
    const h = JSON.parse(this.player.header_json());
    this.header = h;
    this.window = Math.max(8, Math.ceil(this.buffer * h.fps));
    this.bounded = h.frames > 2 * this.window + 4;
    this._newDecoders();
    this.dispatchEvent(new Event('loadedmetadata'));
  }

  /** How far frame k lies ahead of the current one (around the loop). */
  _ahead(k) {
    return k >= this.current ? k - this.current : k + this.header.frames - this.current;
  }

  /** Whether to decode frame k now, and to keep it. */
  _wants(k) {
    if (!this.bounded) return { go: true, keep: true };
    const seeking = this.seekTo !== null && k < this.seekTo;
    const d = this._ahead(k);
    return { go: seeking || d <= this.window, keep: !seeking && d <= this.window };
  }

  /** Drops the frames outside [current - 2, current + window] (a long motion only). */
  _evict() {
    if (!this.bounded) return;
    const n = this.header.frames;
    for (const key in this.frames) {
      const k = +key, behind = (this.current - k + n) % n;
      if (behind > 2 && this._ahead(k) > this.window) { delete this.frames[k]; this.held--; }
    }
  }

  /** One WebCodecs decoder per stream, each at its stream's size (format
   * v9 may code a stream on a grid halved `shrink` times). */
  _newDecoders() {
    const h = this.header;
    this.decoders?.forEach((d) => d.close());
    this.decoders = h.streams.map((s) => new LumaDecoder(h.grid >> (s.shrink || 0)));
  }

  /** Starts decoding again at random-access point r (0: the start). */
  _restart(r) {
    this._newDecoders();
    this.player.seek(r);
    this.restartAt = null;
  }

  /** The consumer now shows frame f: frames behind it may go, decoding goes on. */
  setCurrent(f) {
    if (f === this.current) return;
    this.current = f;
    this._evict();
    if (this.bounded) this.pump();
    this._fill();
  }

  /** Makes frame f the current one; true if it is held now, else a
   * "seeked" event follows once it is (decoding from the random-access
   * point before it when f lies behind the decoder or past that point). */
  seek(f) {
    this.current = f;
    this._evict();
    if (this.frames[f]) {
      // Held: an earlier seek still on its way is over.
      this.seekTo = null;
      this.restartAt = null;
      return true;
    }
    this.seekTo = f;
    // Where decoding goes on from: a restart an earlier seek asked for
    // (not yet begun), else the decoder's next frame.
    const next = this.restartAt ?? this.player.next_frame(), r = this.player.random_access_point(f);
    if (next > f || r > next) this.restartAt = r;
    this._evict();
    this.pump();
    this._fill();
    return false;
  }

  async pump() {
    if (this.pumping || this.closed || !this.header) return;
    this.pumping = true;
    const h = this.header;
    try {
      for (;;) {
        if (this.closed) return;
        if (this.restartAt !== null) this._restart(this.restartAt);
        let f = this.player.next_frame();
        if (f >= h.frames) {
          // The end of a lap: a long looping motion starts the next one.
          if (!(this.bounded && this.loop)) break;
          this._restart(0);
          f = 0;
        }
        if (!this.player.frame_arrived(f)) break; // _fill or the stream wakes the pump
        const want = this._wants(f);
        if (!want.go) break; // the window is full; setCurrent wakes the pump
        const t = performance.now();
        const lumas = await Promise.all(h.streams.map((_, s) =>
          this.player.has_frame(s, f) ? this.decoders[s].decode(this.player.access_unit(s, f), f) : null));
        const t1 = performance.now();
        if (this.closed) return;
        lumas.forEach((l, s) => { if (l) this.player.supply_luma(s, l); });
        const x = this.player.decode_next();
        // A tiny part's vertices (format v11) belong to this frame: they go with it.
        x.loose = this.player.loose_vertices();
        // So does what the decoder adds at the mesh's vertices: the bones'
        // skinning (format v17) and the vertex residual (v18).
        x.skinned = this.player.skinned_vertices();
        // A capture's own mesh of this frame (format v16), while its bytes are here.
        if (h.frame_meshes) {
          const m = this.player.frame_mesh(f, x);
          x.mesh = { faces: m.faces, vertices: m.vertices };
          m.free();
        }
        const t2 = performance.now();
        const st = this.stats, k = st.decoded;
        st.decodeMs = (st.decodeMs * k + (t1 - t)) / (k + 1);
        st.reconstructMs = (st.reconstructMs * k + (t2 - t1)) / (k + 1);
        st.decoded = k + 1;
        const [bytes, frames] = this.ranged ? [this.total, h.frames] : [this.fetched, this.player.complete_frames()];
        st.kbps = bytes * 8 / 1000 / (Math.max(1, frames) / h.fps);
        if (want.keep && !this.frames[f]) {
          this.frames[f] = x;
          this.held++;
          this.dispatchEvent(new CustomEvent('frame', { detail: f }));
        }
        if (f === this.seekTo) {
          this.seekTo = null;
          this.dispatchEvent(new CustomEvent('seeked', { detail: f }));
        }
        // Let the page breathe between frames.
        await new Promise((r) => setTimeout(r, 0));
      }
    } catch (e) {
      if (!this.closed) this.dispatchEvent(new CustomEvent('error', { detail: e.message || String(e) }));
    } finally {
      this.pumping = false;
    }
  }
}
