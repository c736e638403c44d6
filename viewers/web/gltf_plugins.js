// gltf_plugins.js — the GLTFLoader plugins a meshmux stream builds its base .glb with
// (meshmux.js _buildBase): each mesh in a task of its own (TaskPerMesh), the embedded images
// decoded in the stream's worker (TexturesInWorker).

import { textureOf } from './stream_mesh.js';
import { nextTask } from './upload.js';

// A GLTFLoader plugin that builds each mesh of a base in a task of its own. GLTFLoader's parse
// is a web of promises: when a shared buffer view's decode (a worker's reply) resolves, every
// accessor, geometry and mesh waiting on it is built in that one task's microtasks, and the
// scene after them; a base of many meshes held the page for tens of milliseconds per reply.
// Here a mesh first waits for its accessors and materials, then for a task boundary, then is
// built (GLTFParser.loadMesh, finding them ready); a Draco primitive's accessors are not asked
// for (the extension decodes them), nor are morph targets' (built with the mesh, as before).
export class TaskPerMesh {
  constructor(parser) {
    this.parser = parser;
    this.name = 'meshmux_task_per_mesh';
  }

  async loadMesh(index) {
    const parser = this.parser, def = parser.json.meshes && parser.json.meshes[index];
    const ready = [];
    for (const primitive of (def && def.primitives) || []) {
      const draco = primitive.extensions && primitive.extensions.KHR_draco_mesh_compression;
      if (!draco) {
        for (const a of Object.values(primitive.attributes || {})) ready.push(parser.getDependency('accessor', a));
        if (primitive.indices !== undefined) ready.push(parser.getDependency('accessor', primitive.indices));
      }
      if (primitive.material !== undefined) ready.push(parser.getDependency('material', primitive.material));
    }
    await Promise.all(ready).catch(() => {});  // a failure is GLTFParser.loadMesh's to report, as it would
    await nextTask();
    return parser.loadMesh(index);
  }
}

// A GLTFLoader plugin that decodes a base's embedded PNG and JPEG images in the stream's
// worker (`decode(bytes, mime, own)`: an ImageBitmap or a PixelImage), its bytes handed over as
// the buffer view GLTFLoader read. GLTFLoader's own way copies each image into a Blob and
// fetches that on the page's thread (for a base's full-size kept images, up to 20 ms a task).
// GLTFLoader still makes the texture (sampler, name, associations) from what this gives; an
// image with a texture extension (WebP, KTX2) or a URI is left to it.
export class TexturesInWorker {
  constructor(parser, decode) {
    this.parser = parser;
    this.decode = decode;
    this.name = 'meshmux_textures_in_worker';
  }

  loadTexture(index) {
    const json = this.parser.json, def = json.textures && json.textures[index];
    if (!def || (def.extensions && Object.keys(def.extensions).length)) return null;
    const source = json.images && json.images[def.source];
    if (!source || source.bufferView === undefined || !['image/png', 'image/jpeg'].includes(source.mimeType)) return null;
    // GLTFLoader (r187) hands a KTX2 loader the buffer view's bytes as they are (no Blob):
    // this loader is one in that respect only. Should a later GLTFLoader load it by URL (the
    // Blob's) instead, it fetches that and decodes the same way.
    const decode = this.decode, mime = source.mimeType, own = this._onlyUser(source.bufferView);
    const loader = {
      isKTX2Loader: true,
      parse(buffer, onLoad, onError) {
        decode(new Uint8Array(buffer), mime, own).then((image) => {
          const texture = textureOf(image);
          texture.needsUpdate = true;
          onLoad(texture);
        }, onError);
      },
      load(url, onLoad, onProgress, onError) {
        fetch(url).then((r) => r.arrayBuffer()).then((buffer) => loader.parse(buffer, onLoad, onError), onError);
      },
    };
    return this.parser.loadTextureImage(index, def.source, loader);
  }

  // Whether the buffer view holds this image alone (no accessor, no other image reads it): its
  // bytes may then be given to the worker rather than copied. Users counted once per base.
  _onlyUser(view) {
    if (!this._users) {
      const json = this.parser.json, users = (this._users = new Map());
      const use = (v) => { if (v !== undefined) users.set(v, (users.get(v) || 0) + 1); };
      for (const i of json.images || []) use(i.bufferView);
      for (const a of json.accessors || []) {
        use(a.bufferView);
        if (a.sparse) { use(a.sparse.indices.bufferView); use(a.sparse.values.bufferView); }
      }
    }
    return this._users.get(view) === 1;
  }
}
