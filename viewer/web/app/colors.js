// Colours of classes (a hue from the class name, the same in every session), robots (by order)
// and the background.
const ROBOT_PALETTE = [0x00e5ff, 0xff4081, 0x76ff03, 0xffab00, 0xd500f9, 0x2979ff];

export const BACKGROUND = 0x8c8c8c;
export const HIGHLIGHT = 0xffd400;

export function classColour(name) {
  let h = 0;
  for (const c of name) h = (h * 31 + c.codePointAt(0)) >>> 0;
  const hue = (h * 0.6180339887) % 1;  // golden-ratio steps spread near hashes apart
  return hslToHex(hue, 0.75, 0.58);
}

function hslToHex(h, s, l) {
  const f = (n) => {
    const k = (n + h * 12) % 12;
    const v = l - s * Math.min(l, 1 - l) * Math.max(-1, Math.min(k - 3, 9 - k, 1));
    return Math.round(255 * v);
  };
  return (f(0) << 16) | (f(8) << 8) | f(4);
}

export function robotColour(index) {
  return ROBOT_PALETTE[index % ROBOT_PALETTE.length];
}

// A packed 0xRRGGBB as [r, g, b] in [0, 1].
export function rgbFloats(rgb) {
  return [(rgb >> 16 & 255) / 255, (rgb >> 8 & 255) / 255, (rgb & 255) / 255];
}

export function cssColour(hex) {
  return '#' + hex.toString(16).padStart(6, '0');
}
