// The map over time: where each object was at a map time T, from its place history (Object
// `history`, oldest first: APPEARED, MOVED with the earlier place, REMOVED). Pure functions of
// the objects' JSON as api/objects returns them; stamps are BigInt nanoseconds (proto3 JSON
// prints int64 as strings), T = null is "now".

// A stamp as BigInt nanoseconds (0n when absent).
export function toNs(s) {
  if (s === undefined || s === null || s === '') return 0n;
  return typeof s === 'number' ? BigInt(Math.round(s)) : BigInt(s);
}

// The place history with the defaults of proto3 JSON filled in (APPEARED is enum 0, so it may
// be left out): [{kind, tNs, at, from}], oldest first.
export function placeChanges(o) {
  return (o.history || []).map((c) => ({
    kind: c.kind || 'APPEARED',
    tNs: toNs(c.tNs),
    at: c.centroidM || o.centroidM,
    from: c.fromM || c.centroidM || o.centroidM,
  }));
}

// Where an entry puts the object: a removal at the place found empty, else where it was seen.
const placeOf = (c) => (c.kind === 'REMOVED' ? c.from : c.at);

// Found gone (now): removed_t_ns set, or the history ends in a removal.
export function isGone(o) {
  const h = placeChanges(o);
  return toNs(o.removedTNs) !== 0n || (h.length > 0 && h[h.length - 1].kind === 'REMOVED');
}

// The map time it first appears: its first sighting, or its first history entry if earlier.
export function appearedNs(o) {
  const stamps = [toNs(o.firstSeenNs), ...placeChanges(o).slice(0, 1).map((c) => c.tNs)];
  const known = stamps.filter((t) => t > 0n);
  return known.length ? known.reduce((a, b) => (b < a ? b : a)) : 0n;
}

// The newest stamp an object carries: last seen, a history entry or its removal.
export function newestNs(o) {
  const stamps = [toNs(o.lastSeenNs), toNs(o.removedTNs), ...placeChanges(o).map((c) => c.tNs)];
  return stamps.reduce((a, b) => (b > a ? b : a), 0n);
}

// {minNs, maxNs} over the objects (BigInt), or null when none carries a stamp.
export function timeRange(objects) {
  let min = 0n, max = 0n;
  for (const o of objects) {
    const first = appearedNs(o), last = newestNs(o);
    if (first > 0n && (min === 0n || first < min)) min = first;
    if (last > max) max = last;
  }
  if (max === 0n) return null;
  return { minNs: min === 0n || min > max ? max : min, maxNs: max };
}

// The object as the map held it at time t (null = now), or null when it had not appeared yet:
// {gone, at (its centroid then), ghosts: [{from, to}] (each earlier place it moved away from,
// and where it went)}. On its newest place it is at its current centroid.
export function stateAt(o, t) {
  if (t !== null && appearedNs(o) > t) return null;
  const h = placeChanges(o);
  const past = t === null ? h : h.filter((c) => c.tNs <= t);
  const current = past.length === h.length;
  const last = past[past.length - 1];
  const removedNs = toNs(o.removedTNs);
  const gone = (last !== undefined && last.kind === 'REMOVED') ||
               (current && removedNs !== 0n && (t === null || removedNs <= t));
  let at = o.centroidM;
  if (!current) at = last ? placeOf(last) : placeOf(h[0]);
  const ghosts = [];
  past.forEach((c, i) => {
    if (c.kind !== 'MOVED') return;
    const newest = i === h.length - 1;
    ghosts.push({ from: c.from, to: newest ? o.centroidM : c.at });
  });
  return { gone, at, ghosts };
}

// The time at `fraction` in [0, 1] of the range (1 = now, null).
export function timeAtFraction(range, fraction) {
  if (!range || fraction >= 1) return null;
  const steps = 1000000n;
  const k = BigInt(Math.round(Math.max(0, fraction) * 1000000));
  return range.minNs + ((range.maxNs - range.minNs) * k) / steps;
}

// Where t lies in the range, in [0, 1] (now = 1).
export function fractionOfTime(range, t) {
  if (!range || t === null || range.maxNs <= range.minNs) return 1;
  if (t <= range.minNs) return 0;
  if (t >= range.maxNs) return 1;
  return Number(((t - range.minNs) * 1000000n) / (range.maxNs - range.minNs)) / 1000000;
}

// A readable map time: "now", else how long before the newest stamp and the wall time of the
// stamp (UTC), e.g. "2.0 d before newest (2023-11-14 22:13:20 UTC)".
export function describeTime(range, t) {
  if (t === null || !range || t >= range.maxNs) return 'now';
  const before = Number(range.maxNs - t) / 1e9;
  const stamp = new Date(Number(t / 1000000n)).toISOString().replace('T', ' ').slice(0, 19);
  return `${formatSpan(before)} before newest (${stamp} UTC)`;
}

function formatSpan(s) {
  if (s < 90) return `${s.toFixed(s < 10 ? 1 : 0)} s`;
  if (s < 90 * 60) return `${(s / 60).toFixed(0)} min`;
  if (s < 36 * 3600) return `${(s / 3600).toFixed(1)} h`;
  return `${(s / 86400).toFixed(1)} d`;
}
