// The live drawing on a canvas: the world, the mission's marks, the drones with headings.
const MARGIN = 10;

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

function drawDrone(ctx, x, y, heading, followed) {
  const rad = (heading * Math.PI) / 180; // clockwise from north
  const dx = Math.sin(rad);
  const dy = -Math.cos(rad);
  const size = followed ? 9 : 6;
  ctx.beginPath();
  ctx.moveTo(x + dx * size, y + dy * size);
  ctx.lineTo(x - dx * size * 0.6 - dy * size * 0.5, y - dy * size * 0.6 + dx * size * 0.5);
  ctx.lineTo(x - dx * size * 0.6 + dy * size * 0.5, y - dy * size * 0.6 - dx * size * 0.5);
  ctx.closePath();
  ctx.fillStyle = followed ? "#d81b60" : "#1e88e5";
  ctx.fill();
}

/** Draw ``frame`` (positions, headings) and ``marks`` on ``canvas``. */
export function drawWorld(canvas, frame, marks, follow) {
  const ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!frame || !frame.world) return;
  const t = transform(canvas, frame.world);
  ctx.strokeStyle = "#999";
  ctx.strokeRect(t.sx(0), t.sy(frame.world[1]), frame.world[0] * t.scale, frame.world[1] * t.scale);
  for (const mark of marks || []) drawMark(ctx, t, mark);
  const altitude = frame.altitude || [];
  for (let i = 0; i < frame.x.length; i++) {
    const x = t.sx(frame.x[i]);
    const y = t.sy(frame.y[i]);
    drawDrone(ctx, x, y, frame.heading[i] ?? 0, i === follow);
    if (altitude.length && (i === follow || frame.x.length <= 20)) {
      ctx.fillStyle = "#333";
      ctx.fillText(`z ${altitude[i].toFixed(1)}`, x + 8, y + 10);
    }
  }
}

/** Where drone ``i`` of ``frame`` is drawn, in canvas pixels. */
export function agentPixel(canvas, frame, i) {
  const t = transform(canvas, frame.world);
  return { x: t.sx(frame.x[i]), y: t.sy(frame.y[i]) };
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

/** The live plot: mean (blue) and lowest (red) energy, percent, against the iteration. */
export function drawPlot(canvas, series, iterations) {
  const ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.strokeStyle = "#999";
  ctx.strokeRect(0.5, 0.5, canvas.width - 1, canvas.height - 1);
  ctx.fillStyle = "#333";
  ctx.fillText("energy %: mean (blue), lowest (red)", 6, 12);
  if (!series || series.length < 2) return;
  const sx = (it) => (it / iterations) * (canvas.width - 2) + 1;
  const sy = (v) => canvas.height - 2 - (Math.max(0, Math.min(100, v)) / 100) * (canvas.height - 18);
  for (const [key, colour] of [["mean", "#1e88e5"], ["low", "#c62828"]]) {
    ctx.beginPath();
    ctx.strokeStyle = colour;
    series.forEach((point, i) => {
      const x = sx(point.iteration);
      const y = sy(point[key]);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.stroke();
  }
}
