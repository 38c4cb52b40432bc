// The live drawing on a canvas, as the GIF draws a frame: the world and the mission's marks
// (drawn once, then copied), the drones with their headings (in one path per colour), the
// altitude of 3-D drones as their colour, and the recent events: diamonds where they
// happened, a message's lines from its sender to the receivers in range, and a banner.
const MARGIN = 10;
const DRONE = "#1e88e5";
const FOLLOWED = "#d81b60";
const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
const ALTITUDE_BINS = 16;

function transform(canvas, world) {
  const scale = Math.min((canvas.width - 2 * MARGIN) / world[0], (canvas.height - 2 * MARGIN) / world[1]);
  return {
    scale,
    sx: (x) => MARGIN + x * scale,
    sy: (y) => canvas.height - MARGIN - y * scale,
  };
}

function drawMark(ctx, t, mark) {
  ctx.strokeStyle = mark.colour;
  ctx.fillStyle = mark.colour;
  if (mark.shape === "circle") {
    ctx.beginPath();
    ctx.arc(t.sx(mark.x), t.sy(mark.y), Math.max(2, mark.size * t.scale), 0, 2 * Math.PI);
    if (mark.fill) ctx.fill(); else ctx.stroke();
  } else if (mark.shape === "rect") {
    const w = mark.width * t.scale;
    const h = mark.height * t.scale;
    if (mark.fill) ctx.fillRect(t.sx(mark.x), t.sy(mark.y) - h, w, h);
    else ctx.strokeRect(t.sx(mark.x), t.sy(mark.y) - h, w, h);
  } else {
    const x = t.sx(mark.x);
    const y = t.sy(mark.y);
    ctx.beginPath();
    ctx.moveTo(x - 4, y - 4); ctx.lineTo(x + 4, y + 4);
    ctx.moveTo(x + 4, y - 4); ctx.lineTo(x - 4, y + 4);
    ctx.stroke();
  }
  if (mark.label) {
    ctx.fillStyle = "#333";
    ctx.fillText(mark.label, t.sx(mark.x) + 5, t.sy(mark.y) - 5);
  }
}

// The static part (world box, marks) on a canvas of its own, made again only when the
// canvas size, the world or the marks change.
const backgrounds = new WeakMap();

function background(canvas, world, marks) {
  const cached = backgrounds.get(canvas);
  if (cached && cached.world === world.join() && cached.marks === marks
      && cached.image.width === canvas.width && cached.image.height === canvas.height) {
    return cached.image;
  }
  const image = document.createElement("canvas");
  image.width = canvas.width;
  image.height = canvas.height;
  const ctx = image.getContext("2d");
  const t = transform(canvas, world);
  ctx.strokeStyle = "#999";
  ctx.strokeRect(t.sx(0), t.sy(world[1]), world[0] * t.scale, world[1] * t.scale);
  for (const mark of marks || []) drawMark(ctx, t, mark);
  backgrounds.set(canvas, { world: world.join(), marks, image });
  return image;
}

/** The colour of altitude ``z`` on a scale up to ``top`` (dark low, yellow high). */
export function altitudeColour(z, top) {
  const t = 4 * Math.max(0, Math.min(1, z / top));
  const i = Math.min(3, Math.floor(t));
  const c = VIRIDIS[i].map((v, k) => Math.round(v + (VIRIDIS[i + 1][k] - v) * (t - i)));
  return `rgb(${c.join(",")})`;
}

// One drone's triangle (pointing along its heading, degrees clockwise from north), added
// to the current path.
function triangle(ctx, x, y, heading, size) {
  const rad = (heading * Math.PI) / 180;
  const dx = Math.sin(rad);
  const dy = -Math.cos(rad);
  ctx.moveTo(x + dx * size, y + dy * size);
  ctx.lineTo(x - dx * size * 0.6 - dy * size * 0.5, y - dy * size * 0.6 + dx * size * 0.5);
  ctx.lineTo(x - dx * size * 0.6 + dy * size * 0.5, y - dy * size * 0.6 - dx * size * 0.5);
  ctx.closePath();
}

// The drones, one path (one fill) per colour: blue, or the altitude's bin.
function drawDrones(ctx, t, frame, follow, top) {
  const { x, y, heading } = frame;
  const altitude = frame.altitude || [];
  const bins = altitude.length ? ALTITUDE_BINS : 1;
  const paths = Array.from({ length: bins }, () => new Path2D());
  for (let i = 0; i < x.length; i++) {
    if (i === follow) continue;
    const bin = bins > 1 ? Math.min(bins - 1, Math.floor((altitude[i] / top) * bins)) : 0;
    triangle(paths[Math.max(0, bin)], t.sx(x[i]), t.sy(y[i]), heading[i] ?? 0, 6);
  }
  paths.forEach((path, bin) => {
    ctx.fillStyle = bins > 1 ? altitudeColour(((bin + 0.5) / bins) * top, top) : DRONE;
    ctx.fill(path);
  });
  if (follow !== null && follow < x.length) {
    ctx.beginPath();
    triangle(ctx, t.sx(x[follow]), t.sy(y[follow]), heading[follow] ?? 0, 9);
    ctx.fillStyle = FOLLOWED;
    ctx.fill();
  }
  if (!altitude.length) return;
  altitudeLegend(ctx, ctx.canvas, top);
  ctx.fillStyle = "#333";
  for (let i = 0; i < x.length; i++) {
    if (i === follow || x.length <= 20) {
      ctx.fillText(`z ${altitude[i].toFixed(1)}`, t.sx(x[i]) + 8, t.sy(y[i]) + 10);
    }
  }
}

// The altitude's colour scale, in the upper right corner: 0 to ``top`` world units.
function altitudeLegend(ctx, canvas, top) {
  const left = canvas.width - MARGIN - 110;
  const gradient = ctx.createLinearGradient(left, 0, left + 60, 0);
  VIRIDIS.forEach((c, k) => gradient.addColorStop(k / 4, `rgb(${c.join(",")})`));
  ctx.fillStyle = gradient;
  ctx.fillRect(left, MARGIN + 4, 60, 8);
  ctx.fillStyle = "#333";
  ctx.fillText(`z 0..${top.toFixed(0)}`, left + 64, MARGIN + 12);
}

// The recent events: a message's lines to the receivers in range, then a diamond at each
// event's place, then a banner with the newest one.
function drawEvents(ctx, t, events) {
  const drawn = { diamonds: 0, lines: 0, banner: "" };
  ctx.save();
  ctx.setLineDash([4, 3]);
  for (const event of events) {
    if (!event.from || !event.to || !event.to.length) continue;
    ctx.strokeStyle = event.colour;
    ctx.beginPath();
    for (const [x, y] of event.to) {
      ctx.moveTo(t.sx(event.from[0]), t.sy(event.from[1]));
      ctx.lineTo(t.sx(x), t.sy(y));
    }
    ctx.stroke();
    drawn.lines += event.to.length;
  }
  ctx.restore();
  for (const event of events) {
    if (event.x === null || event.y === null) continue;
    const x = t.sx(event.x);
    const y = t.sy(event.y);
    ctx.beginPath();
    ctx.moveTo(x, y - 7); ctx.lineTo(x + 7, y); ctx.lineTo(x, y + 7); ctx.lineTo(x - 7, y);
    ctx.closePath();
    ctx.fillStyle = event.colour;
    ctx.fill();
    ctx.strokeStyle = "#fff";
    ctx.stroke();
    drawn.diamonds += 1;
  }
  const newest = events[events.length - 1];
  if (newest) {
    drawn.banner = `iteration ${newest.iteration}: ${newest.text}`.slice(0, 80);
    ctx.fillStyle = newest.colour;
    ctx.fillText(drawn.banner, MARGIN + 4, MARGIN + 12);
  }
  return drawn;
}

/** Draw ``frame`` (positions, headings, altitudes, recent events) and ``marks`` on
 * ``canvas``; ``top`` is the altitude drawn yellow. Returns what was drawn (for tests). */
export function drawWorld(canvas, frame, marks, follow, top = 1) {
  const ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!frame || !frame.world) return null;
  ctx.drawImage(background(canvas, frame.world, marks), 0, 0);
  const t = transform(canvas, frame.world);
  drawDrones(ctx, t, frame, follow, top);
  return { drones: frame.x.length, ...drawEvents(ctx, t, frame.events || []) };
}

/** Where drone ``i`` of ``frame`` is drawn, in canvas pixels. */
export function agentPixel(canvas, frame, i) {
  const t = transform(canvas, frame.world);
  return { x: t.sx(frame.x[i]), y: t.sy(frame.y[i]) };
}

/** Where world point (x, y) is drawn, in canvas pixels. */
export function worldPixel(canvas, frame, x, y) {
  const t = transform(canvas, frame.world);
  return { x: t.sx(x), y: t.sy(y) };
}

/** The index of the drone nearest the click ``event`` on ``canvas`` (null: none near). */
export function nearestAgent(canvas, frame, event) {
  if (!frame || !frame.world) return null;
  const t = transform(canvas, frame.world);
  const box = canvas.getBoundingClientRect();
  const px = (event.clientX - box.left) * (canvas.width / box.width);
  const py = (event.clientY - box.top) * (canvas.height / box.height);
  let best = null;
  let bestDistance = 15;
  for (let i = 0; i < frame.x.length; i++) {
    const d = Math.hypot(t.sx(frame.x[i]) - px, t.sy(frame.y[i]) - py);
    if (d < bestDistance) { best = i; bestDistance = d; }
  }
  return best;
}

function polyline(ctx, series, key, sx, sy) {
  ctx.beginPath();
  let first = true;
  for (const point of series) {
    if (point[key] === undefined) continue;
    const x = sx(point.iteration);
    const y = sy(point[key]);
    if (first) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    first = false;
  }
  ctx.stroke();
}

function frameOf(ctx, canvas, title) {
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.strokeStyle = "#999";
  ctx.strokeRect(0.5, 0.5, canvas.width - 1, canvas.height - 1);
  ctx.fillStyle = "#333";
  ctx.fillText(title, 6, 12);
}

/** The energy plot: mean (blue) and lowest (red) energy, percent, against the iteration. */
export function drawPlot(canvas, series, iterations) {
  const ctx = canvas.getContext("2d");
  frameOf(ctx, canvas, "energy %: mean (blue), lowest (red)");
  series = (series || []).filter((point) => point.mean !== undefined);
  if (series.length < 2) return;
  const sx = (it) => (it / iterations) * (canvas.width - 2) + 1;
  const sy = (v) => canvas.height - 2 - (Math.max(0, Math.min(100, v)) / 100) * (canvas.height - 18);
  for (const [key, colour] of [["mean", "#1e88e5"], ["low", "#c62828"]]) {
    ctx.strokeStyle = colour;
    polyline(ctx, series, key, sx, sy);
  }
}

/** Colours of the measures' lines (the GIF's event colours; collisions in orange). */
export const MEASURE_COLOURS = { alerts: "#d62728", collisions: "#ff7f0e", messages: "#9467bd" };

/** The measures plot: per measure (alerts, collisions, messages: whatever the scenario
 * reports), the count so far against the iteration, on one scale up to the largest.
 * Returns the legend drawn (for tests). */
export function drawMeasures(canvas, series, names, iterations) {
  const ctx = canvas.getContext("2d");
  const last = series && series.length ? series[series.length - 1] : {};
  const legend = names.map((name) => `${name} ${last[name] ?? 0}`);
  frameOf(ctx, canvas, "so far:");
  let left = 52;
  names.forEach((name, k) => {
    ctx.fillStyle = MEASURE_COLOURS[name] || "#555";
    ctx.fillText(legend[k], left, 12);
    left += ctx.measureText(legend[k]).width + 14;
  });
  if (!series || series.length < 2) return legend;
  const top = Math.max(1, ...names.map((name) => last[name] ?? 0));
  ctx.fillStyle = "#777";
  ctx.fillText(String(top), canvas.width - 6 - ctx.measureText(String(top)).width, 12);
  const sx = (it) => (it / iterations) * (canvas.width - 2) + 1;
  const sy = (v) => canvas.height - 2 - (v / top) * (canvas.height - 18);
  for (const name of names) {
    ctx.strokeStyle = MEASURE_COLOURS[name] || "#555";
    polyline(ctx, series, name, sx, sy);
  }
  return legend;
}
