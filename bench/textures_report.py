#!/usr/bin/env python3
"""The table of bench/textures.sh: per model, the default path against --textures ktx2 (conversion
seconds, texture bytes, GPU bytes, the page's longest library task, appearance). Reads
WORK/models.tsv, the folders WORK/{default,ktx2}/NAME/ (report.json, model.glb),
WORK/tasks-{default,ktx2}.json and WORK/fid-{default,ktx2}.json; prints markdown."""
import json
import os
import struct
import sys


def glb_json_and_bin(path):
    with open(path, 'rb') as f:
        data = f.read()
    length = struct.unpack_from('<I', data, 12)[0]
    doc = json.loads(data[20:20 + length])
    at = 20 + length
    binary = b''
    if at + 8 <= len(data):
        bin_len = struct.unpack_from('<I', data, at)[0]
        binary = data[at + 8:at + 8 + bin_len]
    return doc, binary, len(data)


def image_size(b, mime):
    """(width, height) from the image's own header, or (0, 0)."""
    if mime == 'image/png' and b[:8] == b'\x89PNG\r\n\x1a\n':
        return struct.unpack('>II', b[16:24])
    if mime == 'image/ktx2' and b[:12] == b'\xabKTX 20\xbb\r\n\x1a\n':
        return struct.unpack_from('<II', b, 20)
    if mime == 'image/jpeg':
        i = 2
        while i + 9 < len(b):
            if b[i] != 0xFF:
                i += 1
                continue
            marker = b[i + 1]
            if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
                h, w = struct.unpack('>HH', b[i + 5:i + 9])
                return w, h
            i += 2 + struct.unpack('>H', b[i + 2:i + 4])[0]
    if mime == 'image/webp' and b[:4] == b'RIFF' and b[12:16] == b'VP8X':
        w = 1 + int.from_bytes(b[24:27], 'little')
        h = 1 + int.from_bytes(b[27:30], 'little')
        return w, h
    return 0, 0


def textures(path):
    """(texture bytes, {mime: bytes}, GPU bytes with mipmaps, glb bytes)."""
    doc, binary, total = glb_json_and_bin(path)
    views = doc.get('bufferViews', [])
    wire, by_mime, gpu = 0, {}, 0.0
    for image in doc.get('images', []):
        view = views[image['bufferView']]
        off = view.get('byteOffset', 0)
        b = binary[off:off + view['byteLength']]
        mime = image.get('mimeType', '?')
        wire += len(b)
        by_mime[mime] = by_mime.get(mime, 0) + len(b)
        w, h = image_size(b, mime)
        gpu += w * h * (1 if mime == 'image/ktx2' else 4) * 4 / 3
    return wire, by_mime, gpu, total


def fidelity(path):
    try:
        with open(path) as f:
            return {r['model']: r for r in json.load(f)['rows']}
    except (OSError, ValueError, KeyError):
        return {}


def tasks(path):
    """Per folder name: texture_tasks.mjs's row (gpuBytes, libraryLongest, ...)."""
    try:
        with open(path) as f:
            return {os.path.basename(r['dir'].rstrip('/')): r for r in json.load(f)}
    except (OSError, ValueError, KeyError):
        return {}


def level_bytes(folder):
    """The package's texture levels' bytes (the base's level and every texture chunk), or None."""
    try:
        with open(os.path.join(folder, 'report.json')) as f:
            return sum(json.load(f).get('texture_level_bytes', []))
    except (OSError, ValueError):
        return None


def main():
    work = sys.argv[1]
    seconds = {}
    with open(os.path.join(work, 'models.tsv')) as f:
        for line in f:
            name, kind, s = line.rstrip('\n').split('\t')
            seconds[(name, kind)] = s
    kinds = ('default', 'ktx2')
    fid = {k: fidelity(os.path.join(work, f'fid-{k}.json')) for k in kinds}
    tk = {k: tasks(os.path.join(work, f'tasks-{k}.json')) for k in kinds}
    names = sorted({n for n, _ in seconds})
    print('| model | convert s default → ktx2 (×) | stream texture bytes default → ktx2 | model.glb images default → ktx2 '
          '| client GPU bytes default → ktx2 (÷) | longest library task ms default → ktx2 '
          '| unlit dB default → ktx2 | lit dB default → ktx2 | met default / ktx2 |')
    print('|---|---:|---:|---:|---:|---:|---:|---:|---|')
    mb = lambda v: f'{v / 1e6:.2f} MB' if isinstance(v, (int, float)) else '–'
    for n in names:
        sd, sk = seconds.get((n, 'default')), seconds.get((n, 'ktx2'))
        cells = []
        try:
            cells.append(f'{float(sd):.2f} → {float(sk):.2f} ({float(sk) / max(1e-9, float(sd)):.1f}×)')
        except (TypeError, ValueError):
            cells.append(f'{sd} → {sk}')
        folders = [os.path.join(work, k, n) for k in kinds]
        lb = [level_bytes(f) for f in folders]
        cells.append(f'{mb(lb[0])} → {mb(lb[1])}')
        glbs = [os.path.join(f, 'model.glb') for f in folders]
        if all(os.path.exists(p) for p in glbs):
            cells.append(f'{mb(textures(glbs[0])[0])} → {mb(textures(glbs[1])[0])}')
        else:
            cells.append('–')
        td, tq = tk['default'].get(n, {}), tk['ktx2'].get(n, {})
        gd, gq = td.get('gpuBytes'), tq.get('gpuBytes')
        ratio = f' ({gd / gq:.2f})' if gd and gq else ''
        cells.append(f'{mb(gd)} → {mb(gq)}{ratio}')
        ms = lambda r: f'{r["libraryLongest"]:.1f}' if isinstance(r.get('libraryLongest'), (int, float)) else '–'
        cells.append(f'{ms(td)} → {ms(tq)}')
        rd, rk = fid['default'].get(n, {}), fid['ktx2'].get(n, {})
        f = lambda r, k: f'{r[k]:.1f}' if isinstance(r.get(k), (int, float)) else '–'
        cells += [f'{f(rd, "unlit")} → {f(rk, "unlit")}', f'{f(rd, "lit")} → {f(rk, "lit")}',
                  f'{"yes" if rd.get("met") else "no"} / {"yes" if rk.get("met") else "no"}']
        print(f'| {n} | ' + ' | '.join(cells) + ' |')


if __name__ == '__main__':
    main()
