// @ts-check
// Exported pictures: the supersampled snapshot filtered down (Python's export_filter executed).
const SRGB_TO_LINEAR = Float32Array.from({ length: 256 }, (_, i) => {
  const c = i / 255;
  return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
});

/** @param {number} x linear light, 0..1 (held to it) @returns {number} the sRGB byte */
function linearToSrgb8(x) {
  const c = Math.min(Math.max(x, 0), 1);
  const s = c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055;
  return Math.round(s * 255);
}

/**
 * Filter an 8-bit picture of (width * f) x (height * f) pixels, rows `rowBytes` apart (sRGB as
 * the canvas stores it), down to width x height RGBA with Python's separable filter, in linear
 * light with indices clamped to the picture: what pygfx's renderer does for the kernel engine's
 * exports. Returns width * height * 4 bytes (alpha 255).
 * @param {Uint8Array} src the larger picture
 * @param {number} width @param {number} height the output size (pixels)
 * @param {number} rowBytes bytes between rows of src
 * @param {boolean} bgra blue first
 * @param {{factor: number, first: number, weights: number[]}} filter grasswidget.core.engine_inputs.export_filter
 * @returns {Uint8Array}
 */
export function downsample(src, width, height, rowBytes, bgra, filter) {
  const f = filter.factor, first = filter.first, wts = filter.weights, taps = wts.length;
  const sw = width * f, sh = height * f;
  const rx = bgra ? 2 : 0, bx = bgra ? 0 : 2;
  const clampTo = (/** @type {number} */ i, /** @type {number} */ n) => (i < 0 ? 0 : i >= n ? n - 1 : i);
  const rows = new Float32Array(width * sh * 3);  // filtered along x, all source rows
  for (let y = 0; y < sh; y++) {
    const line = y * rowBytes;
    for (let x = 0; x < width; x++) {
      let r = 0, g = 0, b = 0;
      for (let k = 0; k < taps; k++) {
        const i = line + 4 * clampTo(f * x + first + k, sw), w = wts[k];
        r += w * SRGB_TO_LINEAR[src[i + rx]];
        g += w * SRGB_TO_LINEAR[src[i + 1]];
        b += w * SRGB_TO_LINEAR[src[i + bx]];
      }
      const o = 3 * (y * width + x);
      rows[o] = r; rows[o + 1] = g; rows[o + 2] = b;
    }
  }
  const out = new Uint8Array(width * height * 4);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      let r = 0, g = 0, b = 0;
      for (let k = 0; k < taps; k++) {
        const i = 3 * (clampTo(f * y + first + k, sh) * width + x), w = wts[k];
        r += w * rows[i]; g += w * rows[i + 1]; b += w * rows[i + 2];
      }
      const o = 4 * (y * width + x);
      out[o] = linearToSrgb8(r); out[o + 1] = linearToSrgb8(g); out[o + 2] = linearToSrgb8(b); out[o + 3] = 255;
    }
  }
  return out;
}
