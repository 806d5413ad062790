#!/usr/bin/python3
"""render_check.py — helpers for the render-frame end-to-end tests.

Grid files (docs/grid-format.md) are read and written with NumPy; PNG
images are read with Pillow, an independent decoder.  Each subcommand
checks one thing a person would look at and prints one line; it exits 1
with "what was expected, what was found" when the check fails.

  grid-owner IN OUT RULE        add an owner channel: RULE = x-sign
                                (x < 0 → 0, else 1), columns (i < N → 0)
                                or quadrants (four quarters of the rectangle)
  grid-rest IN REST OUT         add a rest channel: REST's positions
  grid-f32 IN OUT               the same grid with f32 instead of f64 channels
  grid-info IN                  level and channels
  grid-node IN I J [SCALE]      node (i, j)'s position × SCALE, as X,Y,Z
  png-size IMG W H              the PNG is W × H, 8-bit RGB
  sphere IMG [--fov F --margin M --tol T]
                                the object is centred, covers the fraction
                                a fitted sphere must, and its silhouette is
                                round and mirror-symmetric
  lit IMG SIDE                  the SIDE (left/right/top/bottom) half of the
                                object is the brighter
  owners IMG LEFT RIGHT         the left half of the object is mostly palette
                                colour LEFT, the right half RIGHT
  colors IMG N                  exactly N palette colours each cover ≥ 5 % of
                                the object (N peers told apart)
  analytic IMG GRID ...         shading of the unit sphere against the exact
                                Blinn–Phong of a perfect sphere, everywhere
                                and near the grid's seams
  compare IMG REF [--mean M --p99 P]
                                differs from the reference by at most M on
                                average and P at the 99th percentile (0..255)
  facets IMG N yes|no           the N commonest colours cover ≥ 90 % of the
                                object (flat facets), or < 50 % (smooth)
  grid-poke IN OUT I J V        set x of node (i, j) to V (e.g. nan)
  colorbar IMG                  the bar runs from viridis' dark end at the
                                bottom to its bright end at the top
"""
import sys

import numpy as np
from PIL import Image

import gridfile

# Okabe-Ito, render-frame's owner palette (by the peer's place: the order
# the grid meets the owners, row by row)
PALETTE = np.array([[0x00, 0x72, 0xb2], [0xe6, 0x9f, 0x00], [0x00, 0x9e, 0x73],
                    [0xd5, 0x5e, 0x00], [0x56, 0xb4, 0xe9], [0xcc, 0x79, 0xa7],
                    [0xf0, 0xe4, 0x42], [0x99, 0x99, 0x99]], float)


def fail(msg):
    print("render_check: " + msg, file=sys.stderr)
    sys.exit(1)


def read_grid(path):
    g = gridfile.read(path)
    return {'level': g['level'], 'step': g['step'], 'time': g['time'],
            'history': g['history'], 'ch': {k: v.copy() for k, v in g['channels'].items()}}


write_grid = gridfile.write_grid


def load_png(path):
    im = Image.open(path)
    if im.format != 'PNG':
        fail(f"{path}: not a PNG but {im.format}")
    return np.asarray(im.convert('RGB')).astype(float)


def object_mask(img):
    """Pixels that differ from the background (the corner pixel)."""
    bg = img[0, 0]
    return np.abs(img - bg).sum(axis=2) > 6


def sync(a):
    """Stored duplicates take the canonical (lowest-index) node's value:
    (2N, j) ≡ (0, j); (i, 0) ≡ (2N−i, 0); (i, N) ≡ (2N−i, N)."""
    h, w = a.shape[:2]
    n = h - 1
    a[:, w - 1] = a[:, 0]
    a[0, n + 1:] = a[0, n - 1::-1]
    a[n, n + 1:] = a[n, n - 1::-1]
    return a


def cmd_grid_owner(src, dst, rule):
    g = read_grid(src)
    h, w = g['ch']['position'].shape[:2]
    n = h - 1
    jj, ii = np.mgrid[0:h, 0:w]
    if rule == 'x-sign':
        own = (g['ch']['position'][:, :, 0] >= 0).astype(np.int32)
    elif rule == 'columns':
        own = sync((ii >= n).astype(np.int32))
    elif rule == 'quadrants':  # four peers, one per quarter of the rectangle
        own = sync((2 * (jj >= n // 2) + (ii >= n)).astype(np.int32))
    else:
        fail(f"unknown rule {rule}")
    g['ch']['owner'] = own.reshape(h, w, 1)
    g['history'] += f"render_check.py grid-owner {rule}\n"
    write_grid(dst, g)
    print(f"ok: {dst}: owner by {rule}: {np.bincount(own.ravel()).tolist()} nodes")


def cmd_grid_rest(src, rest, dst):
    g = read_grid(src)
    r = read_grid(rest)
    if r['level'] != g['level']:
        fail(f"{rest}: level {r['level']}, {src} level {g['level']}")
    g['ch']['rest'] = r['ch']['position'].astype(g['ch']['position'].dtype)
    g['history'] += "render_check.py grid-rest\n"
    write_grid(dst, g)
    print(f"ok: {dst}: rest shape from {rest}")


def cmd_png_size(path, w, h):
    im = Image.open(path)
    if im.size != (int(w), int(h)) or im.mode != 'RGB':
        fail(f"{path}: expected {w}x{h} RGB, got {im.size[0]}x{im.size[1]} {im.mode}")
    print(f"ok: {path}: {w}x{h} RGB")


def silhouette(mask):
    ys, xs = np.nonzero(mask)
    return xs.mean(), ys.mean(), len(xs)


def cmd_sphere(path, fov=30.0, margin=1.1, tol=0.03):
    img = load_png(path)
    H, W = img.shape[:2]
    m = object_mask(img)
    cx, cy, n = silhouette(m)
    if abs(cx - (W - 1) / 2) > 0.01 * W or abs(cy - (H - 1) / 2) > 0.01 * H:
        fail(f"{path}: centroid ({cx:.1f}, {cy:.1f}), expected the centre "
             f"({(W - 1) / 2:.1f}, {(H - 1) / 2:.1f}) within 1 %")
    # A sphere of radius r seen from distance d = margin r / sin(half):
    # its silhouette is a circle of angular radius asin(sin(half)/margin).
    half_y = np.radians(fov) / 2
    half_x = np.arctan(np.tan(half_y) * W / H)
    half = min(half_x, half_y)
    ang = np.arcsin(np.sin(half) / margin)
    R = np.tan(ang) / np.tan(half_y) * H / 2
    want = np.pi * R * R / (W * H)
    got = n / (W * H)
    if abs(got / want - 1) > tol:
        fail(f"{path}: covers {got:.4f} of the image, a fitted sphere {want:.4f} "
             f"(tolerance {tol:.0%})")
    # Round: the boundary's distance from the centroid at every angle.
    ys, xs = np.nonzero(m)
    ang_px = np.arctan2(ys - cy, xs - cx)
    rad = np.hypot(ys - cy, xs - cx)
    bins = ((ang_px + np.pi) / (2 * np.pi) * 180).astype(int) % 180
    rmax = np.zeros(180)
    np.maximum.at(rmax, bins, rad)
    spread = rmax.max() / rmax.min() - 1
    if spread > 0.02 + 2 / R:
        fail(f"{path}: silhouette radius varies by {spread:.2%} around the circle")
    # Mirror-symmetric left to right and top to bottom (about the centroid).
    for name, flipped in (("left-right", m[:, ::-1]), ("top-bottom", m[::-1, :])):
        iou = (m & flipped).sum() / (m | flipped).sum()
        if iou < 0.98:
            fail(f"{path}: {name} mirror image overlaps by {iou:.3f}, expected ≥ 0.98")
    print(f"ok: {path}: centred, covers {got:.4f} (sphere {want:.4f}), radius within "
          f"{spread:.2%}")


def halves(img, m, side):
    H, W = m.shape
    cx, cy, _ = silhouette(m)
    ys, xs = np.mgrid[0:H, 0:W]
    key = {'left': xs < cx, 'right': xs > cx, 'top': ys < cy, 'bottom': ys > cy}
    other = {'left': 'right', 'right': 'left', 'top': 'bottom', 'bottom': 'top'}[side]
    return m & key[side], m & key[other]


def cmd_lit(path, side):
    img = load_png(path)
    m = object_mask(img)
    a, b = halves(img, m, side)
    la, lb = img[a].mean(), img[b].mean()
    if not la > 1.2 * lb:
        fail(f"{path}: {side} half mean {la:.1f}, other half {lb:.1f}: expected the {side} "
             f"brighter by 20 %")
    print(f"ok: {path}: {side} half {la:.1f} > other half {lb:.1f}")


def cmd_owners(path, left, right):
    img = load_png(path)
    m = object_mask(img)
    L, R = halves(img, m, 'left')
    for name, region, want in (("left", L, int(left)), ("right", R, int(right))):
        px = img[region]
        # the palette colour each pixel's hue is nearest to (shading scales
        # brightness, so compare directions)
        u = px / np.maximum(np.linalg.norm(px, axis=1, keepdims=True), 1)
        p = PALETTE / np.linalg.norm(PALETTE, axis=1, keepdims=True)
        near = np.argmax(u @ p.T, axis=1)
        share = (near == want).mean()
        # the rest: the highlight, the dark limb, the blend at the border
        if share < 0.8:
            counts = np.bincount(near, minlength=len(PALETTE))
            fail(f"{path}: {name} half: {share:.1%} of pixels nearest palette {want}, "
                 f"expected ≥ 80 % (counts {counts.tolist()})")
        print(f"ok: {path}: {name} half {share:.1%} palette colour {want}")


def cmd_colors(path, n):
    img = load_png(path)
    m = object_mask(img)
    px = img[m]
    u = px / np.maximum(np.linalg.norm(px, axis=1, keepdims=True), 1)
    p = PALETTE / np.linalg.norm(PALETTE, axis=1, keepdims=True)
    share = np.bincount(np.argmax(u @ p.T, axis=1), minlength=len(PALETTE)) / max(len(px), 1)
    seen = [k for k in range(len(PALETTE)) if share[k] >= 0.05]
    if len(seen) != int(n):
        fail(f"{path}: {len(seen)} palette colours cover ≥ 5 % of the object, expected {n} "
             f"(shares {np.round(share, 3).tolist()})")
    print(f"ok: {path}: {n} colours, palette {seen}, shares "
          f"{[round(float(share[k]), 3) for k in seen]}")


def cmd_compare(path, ref, mean_tol=2.0, p99_tol=40.0):
    a, b = load_png(path), load_png(ref)
    if a.shape != b.shape:
        fail(f"{path}: {a.shape[1]}x{a.shape[0]}, reference {ref} {b.shape[1]}x{b.shape[0]}")
    d = np.abs(a - b).max(axis=2)
    mean, p99 = d.mean(), np.percentile(d, 99)
    if mean > mean_tol or p99 > p99_tol:
        fail(f"{path}: differs from {ref} by {mean:.2f} on average, {p99:.1f} at the 99th "
             f"percentile (tolerances {mean_tol}, {p99_tol})")
    print(f"ok: {path} ~ {ref}: mean difference {mean:.3f}, 99th percentile {p99:.1f}")


def cmd_facets(path, n, expect):
    """expect = yes: the n most common colours cover ≥ 90 % of the object
    (flat facets); no: they cover less than half (smooth shading)."""
    img = load_png(path)
    m = object_mask(img)
    px = img[m].astype(int)
    keys = (px[:, 0] << 16) | (px[:, 1] << 8) | px[:, 2]
    _, counts = np.unique(keys, return_counts=True)
    share = np.sort(counts)[::-1][:int(n)].sum() / len(keys)
    if (expect == 'yes') != (share >= 0.9) or (expect == 'no' and share >= 0.5):
        fail(f"{path}: the {n} commonest colours cover {share:.1%} of the object "
             f"({'expected ≥ 90 %' if expect == 'yes' else 'expected < 50 %'})")
    print(f"ok: {path}: the {n} commonest colours cover {share:.1%} of the object")


def cmd_colorbar(path):
    img = load_png(path)
    H, W = img.shape[:2]
    # the bar: the rightmost columns whose pixels, over the middle 60 %
    # of the height, are all unlike the background
    bg = img[0, 0]
    rows = slice(int(H * 0.25), int(H * 0.75))
    x = W - 1
    while x > W // 2 and not (np.abs(img[rows, x] - bg).sum(axis=1) > 30).all():
        x -= 1
    if x <= W // 2:
        fail(f"{path}: no colour bar found in the right half")
    x -= 3  # inside the bar, past its frame
    top, bottom = img[int(H * 0.25), x], img[int(H * 0.75), x]
    # viridis: dark purple (68, 1, 84) at 0, yellow (253, 231, 37) at 1
    if not (top[1] > 150 and bottom[1] < 120 and top.sum() > bottom.sum()):
        fail(f"{path}: bar at x={x}: top {top}, bottom {bottom}: expected viridis, bright "
             f"at the top")
    print(f"ok: {path}: colour bar at x={x}, top {top.astype(int)}, bottom {bottom.astype(int)}")


def look_at(eye, center, up):
    f = center - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    return f, s, u


def cmd_analytic(path, grid, *args):
    """The picture of the unit sphere grid against the exact shading of a
    perfect unit sphere seen by the same camera (render-frame's defaults
    with --eye E --center 0,0,0 --up U --light AZ,EL).  The grid is a
    polyhedron, so the normals differ by its discretisation everywhere;
    a wrong normal on a seam would differ along the seam much more."""
    opt = dict(zip(args[::2], args[1::2]))
    eye = np.array([float(v) for v in opt['--eye'].split(',')])
    up = np.array([float(v) for v in opt.get('--up', '0,0,1').split(',')])
    laz, lel = (np.radians(float(v)) for v in opt.get('--light', '-30,30').split(','))
    fov = np.radians(float(opt.get('--fov', '30')))
    tol = float(opt.get("--tol", "5"))
    ka, kd, ks, shin = 0.2, 0.75, 0.25, 40.0
    color = np.array([0xd2, 0xaa, 0x82]) / 255.0
    img = load_png(path)
    H, W = img.shape[:2]
    f, s, u = look_at(eye, np.zeros(3), up)
    ty = np.tan(fov / 2)
    tx = ty * W / H
    ys, xs = np.mgrid[0:H, 0:W]
    px = ((xs + 0.5) / W * 2 - 1) * tx
    py = (1 - (ys + 0.5) / H * 2) * ty
    d = f[None, None] + px[..., None] * s + py[..., None] * u
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    # ray eye + t d meets |x| = 1
    b = (d * eye).sum(axis=2)
    c = eye @ eye - 1
    disc = b * b - c
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0))
    p = eye + t[..., None] * d
    n = p  # the unit sphere's normal
    L = np.cos(lel) * np.sin(laz) * s + np.sin(lel) * u - np.cos(lel) * np.cos(laz) * f
    V = -d
    Hv = L + V
    Hv /= np.linalg.norm(Hv, axis=2, keepdims=True)
    ndl = np.clip((n * L).sum(axis=2), 0, None)
    spec = np.where(ndl > 0, np.clip((n * Hv).sum(axis=2), 0, None) ** shin, 0)
    want = (color * (ka + kd * ndl[..., None]) + ks * spec[..., None]) * 255
    want = np.clip(want, 0, 255)
    # Compare away from the silhouette (where pixels mix sphere and
    # background, and the polygon's outline differs from the circle).
    grazing = (n * V).sum(axis=2)
    inner = hit & (grazing > 0.25) & object_mask(img)
    err = np.abs(img - want).max(axis=2)
    # the seams: stored nodes on the column seam and the two folded rows,
    # projected into the image
    g = read_grid(grid)
    pos = g['ch']['position'].astype(float)
    seam_pts = np.concatenate([pos[:, 0], pos[0, :], pos[-1, :]])
    rel = seam_pts - eye
    z = rel @ f
    vis = (z > 0) & ((seam_pts * (eye - seam_pts)).sum(axis=1) > 0)
    sx = ((rel @ s) / z / tx + 1) / 2 * W - 0.5
    sy = (1 - (rel @ u) / z / ty) / 2 * H - 0.5
    near = np.zeros((H, W), bool)
    for x, y in zip(sx[vis], sy[vis]):
        xi, yi = int(round(x)), int(round(y))
        near[max(yi - 4, 0):yi + 5, max(xi - 4, 0):xi + 5] = True
    near &= inner
    far = inner & ~near
    if inner.sum() < 0.2 * H * W * 0.3:
        fail(f"{path}: only {inner.sum()} sphere pixels to compare")
    e_far = np.percentile(err[far], 99)
    e_near = np.percentile(err[near], 99) if near.any() else 0.0
    if e_far > tol or e_near > tol:
        fail(f"{path}: shading differs from a perfect sphere's by {e_near:.1f} near the "
             f"seams ({near.sum()} px) and {e_far:.1f} elsewhere (99th percentiles, "
             f"tolerance {tol})")
    print(f"ok: {path}: shading within {e_near:.1f} of a perfect sphere's near the seams "
          f"({near.sum()} px), {e_far:.1f} elsewhere (99th percentiles)")


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        sys.exit(2)
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == 'grid-owner':
        cmd_grid_owner(*args)
    elif cmd == 'grid-rest':
        cmd_grid_rest(*args)
    elif cmd == 'grid-f32':
        g = read_grid(args[0])
        g['ch'] = {k: (v.astype(np.float32) if v.dtype == np.float64 else v)
                   for k, v in g['ch'].items()}
        write_grid(args[1], g)
        print(f"ok: {args[1]}: float channels as f32")
    elif cmd == 'grid-info':
        g = read_grid(args[0])
        print(g['level'], {k: v.shape for k, v in g['ch'].items()})
    elif cmd == 'grid-node':
        g = read_grid(args[0])
        scale = float(args[3]) if len(args) > 3 else 1.0
        p = g['ch']['position'][int(args[2]), int(args[1])] * scale
        print(','.join(f"{v:.9g}" for v in p))
    elif cmd == 'png-size':
        cmd_png_size(*args)
    elif cmd == 'sphere':
        opt = dict(zip(args[1::2], args[2::2]))
        cmd_sphere(args[0], float(opt.get('--fov', 30)), float(opt.get('--margin', 1.1)),
                   float(opt.get('--tol', 0.03)))
    elif cmd == 'lit':
        cmd_lit(*args)
    elif cmd == 'owners':
        cmd_owners(*args)
    elif cmd == 'colors':
        cmd_colors(*args)
    elif cmd == 'analytic':
        cmd_analytic(*args)
    elif cmd == 'compare':
        opt = dict(zip(args[2::2], args[3::2]))
        cmd_compare(args[0], args[1], float(opt.get('--mean', 2.0)), float(opt.get('--p99', 40)))
    elif cmd == 'facets':
        cmd_facets(*args)
    elif cmd == 'grid-poke':
        g = read_grid(args[0])
        g['ch']['position'][int(args[3]), int(args[2]), 0] = float(args[4])
        write_grid(args[1], g)
        print(f"ok: {args[1]}: x of node ({args[2]}, {args[3]}) = {args[4]}")
    elif cmd == 'colorbar':
        cmd_colorbar(*args)
    else:
        fail(f"unknown command {cmd}")


if __name__ == '__main__':
    main()
