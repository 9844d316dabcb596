// Parsers of `rhier view`'s binary messages (formats/view.md): a mesh, sent once per
// set of live leaves, and a frame's transforms and colours. Little-endian.

const MESH_MAGIC = 'RHVM';
const FRAME_MAGIC = 'RHVF';
const VERSION = 1;

function magic(view) {
  return String.fromCharCode(view.getUint8(0), view.getUint8(1), view.getUint8(2), view.getUint8(3));
}

function check(view, expected, what) {
  if (view.byteLength < 8 || magic(view) !== expected || view.getUint32(4, true) !== VERSION) {
    throw new Error(`${what}: expected ${expected} version ${VERSION}`);
  }
}

// {key, groups: [{object, positions: Float32Array, indices: Uint32Array, firstVertex}]}
export function parseMesh(buffer) {
  const view = new DataView(buffer);
  check(view, MESH_MAGIC, 'mesh');
  const key = view.getBigUint64(8, true);
  const groups = view.getUint32(16, true);
  const vertices = view.getUint32(20, true);
  const indices = view.getUint32(24, true);
  const posOffset = 32 + 20 * groups;
  const idxOffset = posOffset + 12 * vertices;
  if (buffer.byteLength !== idxOffset + 4 * indices) throw new Error('mesh: wrong length');
  const out = [];
  for (let g = 0; g < groups; g++) {
    const at = 32 + 20 * g;
    const [object, firstVertex, count, firstIndex, indexCount] =
      [0, 4, 8, 12, 16].map((o) => view.getUint32(at + o, true));
    out.push({
      object,
      firstVertex,
      positions: new Float32Array(buffer, posOffset + 12 * firstVertex, 3 * count),
      indices: new Uint32Array(buffer, idxOffset + 4 * firstIndex, indexCount),
    });
  }
  return { key, groups: out };
}

// {key, t, scale, colorsId, transforms: Float32Array (12 per object),
//  colors: Uint16Array (half floats), or null when left out (the client has colorsId's)}
export function parseFrame(buffer) {
  const view = new DataView(buffer);
  check(view, FRAME_MAGIC, 'frame');
  const objects = view.getUint32(24, true);
  const vertices = view.getUint32(28, true);
  const colorOffset = 40 + 48 * objects;
  return {
    key: view.getBigUint64(8, true),
    t: view.getFloat64(16, true),
    scale: view.getFloat32(32, true),
    colorsId: view.getUint32(36, true),
    transforms: new Float32Array(buffer, 40, 12 * objects),
    colors: vertices > 0 ? new Uint16Array(buffer, colorOffset, 3 * vertices) : null,
  };
}
