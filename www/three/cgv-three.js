// A .cgv motion as a three.js mesh, for a page's own scene:
//
//   import { CgvMesh } from './three/cgv-three.js';
//   const mesh = await CgvMesh.load('motion.cgv');     // a THREE.Mesh
//   scene.add(mesh);
//   renderer.setAnimationLoop(() => { mesh.update(clock.getElapsedTime()); renderer.render(scene, camera); });
//
// Its BufferGeometry's positions follow the motion (normals recomputed by
// three each frame); it is the input's own mesh, with its UVs and base
// colour texture, when the file carries them (format v6 to v8), else the
// N x N grid mesh. Decoding is cgv's (cgv-stream.js: WebCodecs for H.264,
// the wasm decoder package www/pkg-decoder/ for the rest: 234 KB gzipped,
// without the renderer of <cgv-player>'s), with the same bounded window as
// <cgv-player>: memory does not grow with the motion's length.
//
// `three` is imported by name: the page maps it (an import map, or a
// bundler), so the page's own three.js is the one used.

import * as THREE from 'three';
import { MotionStream, usePackage } from '../cgv-stream.js';

// The decoder alone (www/pkg-decoder/, no renderer: three draws), unless a
// <cgv-player> on the page asks for the full package (its renderer).
usePackage(new URL('../pkg-decoder/cgv.js', import.meta.url).href, { weak: true });

/** Resolves once the stream holds frame 0 (or rejects with its error). */
function firstFrame(stream) {
  return new Promise((resolve, reject) => {
    const done = () => { if (stream.frames[0]) { stream.removeEventListener('frame', done); resolve(); } };
    stream.addEventListener('frame', done);
    stream.addEventListener('error', (e) => reject(new Error(e.detail)), { once: true });
  });
}

/** The base colour texture of a format-v8 file, as a three.js texture (null without one). */
async function baseColorTexture(player, look) {
  if (!look?.texture) return null;
  const blob = new Blob([player.texture_bytes()], { type: look.texture.mime });
  const texture = new THREE.Texture(await createImageBitmap(blob));
  // glTF's UV origin is the image's top left (as three's GLTFLoader sets it).
  texture.flipY = false;
  texture.colorSpace = THREE.SRGBColorSpace;
  texture.needsUpdate = true;
  return texture;
}

export class CgvMesh extends THREE.Mesh {
  /**
   * Streams a .cgv file (a URL, Blob or ArrayBuffer) and resolves, once its
   * first frame is decoded, to a mesh showing it. Options: `material` (by
   * default a MeshStandardMaterial with the file's base colour and
   * texture), `buffer` (seconds decoded ahead, 3), `loop` (true).
   */
  static async load(source, { material, buffer = 3, loop = true } = {}) {
    const stream = new MotionStream({ buffer, loop });
    const opened = stream.open(source);
    opened.catch(() => {});
    await Promise.race([firstFrame(stream), opened.then(() => firstFrame(stream))]);
    const h = stream.header;
    const hasSource = h.source_mesh && stream.player.source_faces().length > 0;
    const look = hasSource ? h.appearance : null;
    if (!material) {
      const map = look ? await baseColorTexture(stream.player, look).catch(() => null) : null;
      const c = look?.base_color || [0.8, 0.8, 0.8, 1];
      material = new THREE.MeshStandardMaterial({ color: new THREE.Color(c[0], c[1], c[2]), map, roughness: 0.7, side: THREE.DoubleSide });
    }
    return new CgvMesh(stream, material, hasSource, look);
  }

  constructor(stream, material, useSource, look) {
    const p = stream.player;
    const faces = useSource ? p.source_faces() : p.grid_faces();
    const vertices = useSource ? stream.header.source_mesh.vertices : stream.header.grid * stream.header.grid;
    const geometry = new THREE.BufferGeometry();
    geometry.setIndex(new THREE.BufferAttribute(faces, 1));
    const position = new THREE.BufferAttribute(new Float32Array(3 * vertices), 3);
    position.setUsage(THREE.DynamicDrawUsage);
    geometry.setAttribute('position', position);
    const uvs = look ? p.source_uvs() : new Float32Array(0);
    if (uvs.length === 2 * vertices) geometry.setAttribute('uv', new THREE.BufferAttribute(uvs, 2));
    super(geometry, material);
    this.stream = stream;
    this.useSource = useSource;
    /** The frame the geometry holds (-1: none yet). */
    this.frame = -1;
    this.frustumCulled = false; // the motion moves beyond frame 0's bounds
    this.showFrame(0);
  }

  /** Seconds of motion, and its frame rate. */
  get duration() { return this.stream.header.frames / this.stream.header.fps; }
  get fps() { return this.stream.header.fps; }

  /** Shows the frame at `seconds` (looping); returns the frame shown. A
   * frame not decoded yet keeps the last one (decoding catches up). */
  update(seconds) {
    const n = this.stream.header.frames;
    let f = Math.floor(seconds * this.fps + 1e-6);
    f = this.stream.loop ? ((f % n) + n) % n : Math.max(0, Math.min(f, n - 1));
    if (this.stream.frames[f]) this.showFrame(f);
    else if (f < this.frame || f > this.frame + this.stream.window + 1) this.stream.seek(f);
    return this.frame;
  }

  /** Puts decoded frame f in the geometry (it must be held). */
  showFrame(f) {
    if (f === this.frame || !this.stream.frames[f]) return;
    const grid = this.stream.frames[f];
    if (grid.mesh) {
      // A capture's file (format v16): each frame its own mesh (the last
      // frame's buffers released first).
      this.geometry.dispose();
      this.geometry.setIndex(new THREE.BufferAttribute(grid.mesh.faces, 1));
      this.geometry.setAttribute('position', new THREE.BufferAttribute(grid.mesh.vertices, 3));
    } else {
      const x = this.useSource ? this.stream.player.source_vertices(grid, grid.loose, grid.skinned) : grid;
      const position = this.geometry.getAttribute('position');
      position.array.set(x);
      position.needsUpdate = true;
    }
    this.geometry.computeVertexNormals();
    this.geometry.computeBoundingSphere();
    this.frame = f;
    this.stream.setCurrent(f);
  }

  dispose() {
    this.stream.close();
    this.geometry.dispose();
  }
}
