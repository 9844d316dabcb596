// Parsers of `rhier view`'s binary messages (formats/view.md): a span's mesh, sent
// once per span of time, and a frame's transforms and colours. Little-endian.

const MESH_MAGIC = 'RHVM';
const FRAME_MAGIC = 'RHVF';
const VERSION = 2;

function magic(view) {
  return String.fromCharCode(view.getUint8(0), view.getUint8(1), view.getUint8(2), view.getUint8(3));
}

function check(view, expected, what) {
  if (view.byteLength < 8 || magic(view) !== expected || view.getUint32(4, true) !== VERSION) {
    throw new Error(`${what}: expected ${expected} version ${VERSION}`);
  }
}

// {key, groups: [{object, firstVertex, positions: Float32Array (3 per corner),
//  times: Float32Array ([t0, t1] per leaf), corners: Uint8Array (3 or 4 per leaf)}]}
export function parseMesh(buffer) {
  const view = new DataView(buffer);
  check(view, MESH_MAGIC, 'mesh');
  const key = view.getBigUint64(8, true);
  const groups = view.getUint32(16, true);
  const vertices = view.getUint32(20, true);
  const leaves = view.getUint32(24, true);
  const posOffset = 32 + 20 * groups;
  const timeOffset = posOffset + 12 * vertices;
  const cornerOffset = timeOffset + 8 * leaves;
  if (buffer.byteLength !== cornerOffset + 4 * Math.ceil(leaves / 4)) throw new Error('mesh: wrong length');
  const out = [];
  for (let g = 0; g < groups; g++) {
    const at = 32 + 20 * g;
    const [object, firstVertex, count, firstLeaf, leafCount] =
      [0, 4, 8, 12, 16].map((o) => view.getUint32(at + o, true));
    out.push({
      object,
      firstVertex,
      positions: new Float32Array(buffer, posOffset + 12 * firstVertex, 3 * count),
      times: new Float32Array(buffer, timeOffset + 8 * firstLeaf, 2 * leafCount),
      corners: new Uint8Array(buffer, cornerOffset + firstLeaf, leafCount),
    });
  }
  return { key, groups: out };
}

// {key, live, t, scale, colorsId, transforms: Float32Array (12 per object),
//  colors: Uint16Array (half floats, the live leaves' corners in the mesh's order),
//  or null when left out (the client has colorsId's)}
export function parseFrame(buffer) {
  const view = new DataView(buffer);
  check(view, FRAME_MAGIC, 'frame');
  const objects = view.getUint32(32, true);
  const vertices = view.getUint32(36, true);
  const colorOffset = 48 + 48 * objects;
  return {
    key: view.getBigUint64(8, true),
    live: view.getBigUint64(16, true),
    t: view.getFloat64(24, true),
    scale: view.getFloat32(40, true),
    colorsId: view.getUint32(44, true),
    transforms: new Float32Array(buffer, 48, 12 * objects),
    colors: vertices > 0 ? new Uint16Array(buffer, colorOffset, 3 * vertices) : null,
  };
}
