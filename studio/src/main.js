// The studio page: the block editor (Blockly), the parameters, the live canvas and the
// followed drone's tree. Talks to the server of pyautonomousagent.studio (JSON over HTTP).
import * as Blockly from "blockly/core";
import * as En from "blockly/msg/en";
import {
  NAME, ROOT, defineBlocks, loadTree, showStatus, toolbox, treeOf, uniqueNames,
} from "./blocks.js";
import {
  agentPixel, drawMeasures, drawPlot, drawWorld, nearestAgent, worldPixel,
} from "./world.js";

Blockly.setLocale(En);

const $ = (id) => document.getElementById(id);
const FRAME_MS = 1000 / 40; // 40 frames per second while playing, at most
const PANELS_MS = 200; // plots, node list and blocks' labels: 5 times a second while playing
const IDLE_MS = 300;
const state = {
  info: null, ok: false, follow: null, frame: null, playing: false, created: [], top: 1, drawing: null,
};

async function api(path, body, raw) {
  const options = body === undefined ? {} : {
    method: "POST",
    body: raw ? body : JSON.stringify(body),
    headers: { "Content-Type": raw ? "application/octet-stream" : "application/json" },
  };
  const response = await fetch(path, options);
  const data = await response.json();
  if (!response.ok) throw new Error(data.error || response.statusText);
  return data;
}

function say(text, kind) {
  const box = $("message");
  box.textContent = text;
  box.className = kind || "";
}

function setRunnable(ok) {
  state.ok = ok;
  showButtons();
}

// Play and Step need a tree that can run and a run of it (not one whose tree or parameters
// changed since it began: then Reset is offered); Reset and saving need a tree that can run.
function showButtons() {
  const stale = Boolean(state.stale);
  for (const id of ["reset", "save-run", "save-xml", "save-yaml"]) $(id).disabled = !state.ok;
  for (const id of ["play", "step"]) $(id).disabled = !state.ok || stale;
  $("reset").classList.toggle("offer", stale && state.ok);
  setText($("offer"), !stale ? ""
    : state.ok ? `${state.stale}: Reset runs the new one from iteration 0`
      : `${state.stale}; the tree cannot run yet`);
}

// --- the tree -------------------------------------------------------------------------

let checkTimer = null;
let workspace = null;

async function checkTree() {
  checkTimer = null;
  state.checking = true;
  try {
    await checkNow();
    await pollOnce(); // the run may now be one of another tree: Reset is offered
  } catch (error) {
    say(error.message, "error");
  } finally {
    state.checking = false;
  }
}

async function checkNow() {
  const { tree, blocks, roots } = treeOf(workspace);
  for (const block of workspace.getAllBlocks(false)) block.setWarningText(null);
  if (roots > 1) {
    setRunnable(false);
    const text = `the Tree block holds ${roots} nodes; a tree has one root: put them into a Sequence or Fallback`;
    blocks[0].setWarningText(text);
    say(text, "error");
    return;
  }
  try {
    const result = await api("/api/tree", { tree });
    setRunnable(result.ok);
    if (result.ok) {
      say(`the tree can run (${blocks.length} nodes): Play runs it from iteration 0`, "ok");
    } else {
      if (result.block >= 0 && blocks[result.block]) blocks[result.block].setWarningText(result.error);
      say(result.error, "error");
    }
  } catch (error) {
    setRunnable(false);
    say(error.message, "error");
  }
}

function scheduleCheck() {
  clearTimeout(checkTimer);
  checkTimer = setTimeout(checkTree, 250);
}

// A new block starts with its type's name, a copy with its original's; where that name is
// taken, it gets the next free one (in the same undo step as the block's creation).
function named(event) {
  const group = Blockly.Events.getGroup();
  Blockly.Events.setGroup(event.group || group);
  try {
    uniqueNames(workspace, event.ids);
  } finally {
    Blockly.Events.setGroup(group);
  }
}

function startEditor(info) {
  defineBlocks(info.palette);
  workspace = Blockly.inject($("blockly"), {
    toolbox: toolbox(info.palette),
    media: "/static/media/",
    sounds: false,
    trashcan: true,
    move: { scrollbars: true, drag: true, wheel: true },
    zoom: { controls: true, startScale: 0.8 },
  });
  workspace.addChangeListener((event) => {
    if (event.type === Blockly.Events.BLOCK_CREATE) {
      state.created.push(...event.ids);
      named(event);
    }
    if (!event.isUiEvent) {
      state.blocks = null; // the blocks in tree order, found again on the next frame
      scheduleCheck();
    }
  });
  openTree(info.tree);
}

// Replace the canvas with ``tree`` (null: empty) and check it.
function openTree(tree) {
  loadTree(workspace, tree);
  state.blocks = null;
  scheduleCheck();
}

async function upload(file) {
  try {
    const data = await api(`/api/upload?name=${encodeURIComponent(file.name)}`, file, true);
    openTree(data.tree);
  } catch (error) {
    say(error.message, "error");
  }
}

// --- parameters -----------------------------------------------------------------------

function buildSettings(schema) {
  $("scenario").textContent = `${schema.scenario}: ${schema.description}`;
  $("agents").value = schema.agents;
  $("iterations").value = schema.iterations;
  const box = $("params");
  for (const p of schema.parameters) {
    const row = document.createElement("div");
    row.className = "param";
    const range = p.minimum !== null || p.maximum !== null
      ? ` [${p.minimum ?? "-inf"} .. ${p.maximum ?? "inf"}]` : "";
    row.innerHTML = `<label></label><input><small></small>`;
    row.children[0].textContent = p.name;
    row.children[0].title = `${p.owner}: ${p.doc}`;
    row.children[1].value = p.value;
    row.children[1].dataset.param = p.name;
    row.children[1].dataset.type = p.type;
    row.children[2].textContent = `${p.unit}${range}`;
    box.appendChild(row);
  }
}

function readSettings() {
  const parameters = {};
  for (const input of document.querySelectorAll("#params input")) {
    const text = input.value.trim();
    parameters[input.dataset.param] = input.dataset.type === "str" ? text
      : input.dataset.type === "bool" ? text === "true" : text;
  }
  return { parameters, agents: $("agents").value, iterations: $("iterations").value, seed: $("seed").value };
}

async function applySettings() {
  try {
    const result = await api("/api/settings", readSettings());
    await checkTree();
    if (result.stale) {
      say("settings applied: Reset runs them from iteration 0", "ok");
    } else {
      if (state.ok) await control("reset");
      say("settings applied; the run is reset", "ok");
    }
    await pollOnce();
  } catch (error) {
    say(error.message, "error");
  }
}

// --- the run --------------------------------------------------------------------------

async function control(action, extra) {
  try {
    const result = await api("/api/control", { action, speed: Number($("speed").value), ...extra });
    state.playing = result.playing;
    await pollOnce();
  } catch (error) {
    say(error.message, "error");
  }
}

// The node list under the map: its rows are made when the run's tree changes (names as
// text, never as markup), then only the statuses and counts that changed are written.
function showNodes(frame) {
  const box = $("nodes");
  const follow = frame.follow;
  const nodes = frame.nodes || [];
  setText($("follow"), follow
    ? `following ${follow.agent}${follow.statuses ? "" : " (not traced)"}`
    : "Click a drone to follow it; the numbers are how many agents have each node active.");
  const key = nodes.map((node) => `${node.depth} ${node.name}`).join("\n");
  if (state.nodesKey !== key) {
    state.nodesKey = key;
    box.replaceChildren(...nodes.map((node, i) => nodeRow(node, i)));
  }
  const rows = box.children;
  for (let i = 0; i < nodes.length; i++) {
    const status = follow && follow.statuses ? follow.statuses[i] : "invalid";
    const row = rows[i];
    if (row.dataset.status !== status) {
      row.dataset.status = status;
      row.firstChild.className = `st ${status}`;
    }
    setText(row.lastChild, String(frame.active ? frame.active[i] : 0));
  }
  const board = follow && follow.blackboard ? Object.entries(follow.blackboard) : [];
  setText($("blackboard"), board.length
    ? `blackboard of ${follow.agent}: ` + board.map(([k, v]) => `${k} = ${typeof v === "number" ? +v.toFixed(3) : v}`).join(", ")
    : "");
}

function nodeRow(node, i) {
  const row = document.createElement("div");
  row.dataset.node = String(i);
  row.dataset.status = "invalid";
  const mark = document.createElement("span");
  mark.className = "st invalid";
  const count = document.createElement("b");
  row.append(mark, `${"\u00a0\u00a0".repeat(node.depth)}${node.name} `, count);
  return row;
}

function setText(element, text) {
  if (element.textContent !== text) element.textContent = text;
}

// The blocks show the followed agent's statuses and the active counts while the run's tree
// is the one on the canvas (an edit resets the run); a changed label makes Blockly lay its
// block out again.
function colourBlocks(frame) {
  if (!state.blocks) state.blocks = treeOf(workspace).blocks;
  const blocks = state.blocks;
  const nodes = frame.nodes || [];
  const follow = frame.follow && frame.follow.statuses;
  blocks.forEach((block, i) => {
    if (nodes.length === blocks.length && !frame.stale) {
      showStatus(block, follow ? follow[i] : "invalid", frame.active ? frame.active[i] : 0);
    } else {
      showStatus(block, "invalid", 0);
    }
  });
}

// The live plots' series: per iteration seen, the swarm's mean and lowest energy and the
// scenario's measures so far (alerts, collisions, messages: what it reports).
function record(frame) {
  if (!frame.world) return; // no run yet
  const series = state.series || (state.series = []);
  if (series.length && frame.iteration < series[series.length - 1].iteration) {
    series.length = 0;
    state.top = 1;
  }
  if (series.length && frame.iteration === series[series.length - 1].iteration) return;
  const point = { iteration: frame.iteration, ...(frame.measures || {}) };
  if (frame.energy) {
    point.mean = frame.energy.mean;
    point.low = frame.energy.low;
  }
  for (const z of frame.altitude || []) if (z > state.top) state.top = z;
  series.push(point);
}

// Milliseconds spent per part of the frames drawn so far (for scripts/studio_frames.py).
const profile = { frames: 0, new: 0, fetch: 0, world: 0, plots: 0, nodes: 0, blocks: 0 };

// A request for the current frame: {seq, follow, promise}. While playing (``after``: the
// iteration last received) the server answers once the run has moved past it.
let requests = 0;

function requestFrame(after) {
  const query = new URLSearchParams();
  if (state.follow !== null) query.set("follow", state.follow);
  if (after !== undefined) query.set("after", after);
  const promise = api(`/api/frame?${query}`);
  promise.catch(() => {}); // a prefetched frame's error is reported when it is awaited
  requests += 1;
  return { seq: requests, follow: state.follow, promise };
}

// Draw one frame; an answer older than the one drawn, or for another followed drone, is
// dropped.
function show(request, frame) {
  if (request.seq < (state.shownSeq || 0) || request.follow !== state.follow) return;
  state.shownSeq = request.seq;
  let t = performance.now();
  const lap = (part) => {
    const now = performance.now();
    profile[part] += now - t;
    t = now;
  };
  if (!state.frame || frame.iteration !== state.frame.iteration) profile.new += 1;
  state.frame = frame;
  state.drawn = (state.drawn || 0) + 1;
  state.playing = frame.playing;
  if ((frame.stale || "") !== (state.stale || "")) {
    state.stale = frame.stale || "";
    showButtons();
  }
  record(frame);
  const drawing = drawWorld($("world"), frame, state.info.marks, state.follow, state.top);
  lap("world");
  state.drawing = drawing && { ...drawing, measures: state.legend };
  profile.frames += 1;
  // The iteration, plots, node list and blocks' labels: at most every PANELS_MS while playing
  // (the page's layout and painting cost more than the map's), on every frame otherwise.
  const now = performance.now();
  if (frame.playing && now - (state.panelsAt || 0) < PANELS_MS) return;
  state.panelsAt = now;
  setText($("iteration"), `iteration ${frame.iteration} of ${frame.iterations ?? "?"}`);
  drawPlot($("plot"), state.series, frame.iterations || 1);
  const names = Object.keys(frame.measures || {});
  state.legend = drawMeasures($("measures"), state.series, names, frame.iterations || 1);
  state.drawing = drawing && { ...drawing, measures: state.legend };
  lap("plots");
  showNodes(frame);
  lap("nodes");
  colourBlocks(frame);
  lap("blocks");
}

// The current frame, now (after a button or a click).
async function pollOnce() {
  const request = requestFrame();
  show(request, await request.promise);
}

// One request in flight at a time: while playing, the next frame is asked for as soon as
// one arrives, and drawn once this one is (so the server's wait for the run and the page's
// drawing overlap); a frame that arrives late replaces the one before: frames are dropped,
// never queued. At most one frame per FRAME_MS while playing, one per IDLE_MS otherwise.
async function pollLoop() {
  let next = null;
  for (;;) {
    const start = performance.now();
    const request = next || requestFrame();
    next = null;
    try {
      const frame = await request.promise;
      profile.fetch += performance.now() - start;
      if (frame.playing && request.follow === state.follow) next = requestFrame(frame.iteration);
      show(request, frame);
    } catch (error) {
      say(error.message, "error");
    }
    const period = state.playing ? FRAME_MS : IDLE_MS;
    await new Promise((ok) => setTimeout(ok, Math.max(0, period - (performance.now() - start))));
  }
}

async function saveTree(format) {
  try {
    const result = await api("/api/save-tree", { name: $("name").value, format });
    say(`wrote ${result.file}`, "ok");
  } catch (error) {
    say(error.message, "error");
  }
}

async function saveRun() {
  say("running to the end and saving ...", "");
  try {
    const result = await api("/api/save-run", { name: $("name").value, overwrite: $("overwrite").checked });
    say(`saved ${result.folder} (${result.status}); tree ${result.tree}`, "ok");
  } catch (error) {
    say(error.message, "error");
  }
}

function wire() {
  $("start-scenario").onclick = () => openTree(state.info.tree);
  $("start-empty").onclick = () => openTree(null);
  $("upload").onchange = (event) => event.target.files[0] && upload(event.target.files[0]);
  $("save-xml").onclick = () => saveTree("xml");
  $("save-yaml").onclick = () => saveTree("yaml");
  $("save-run").onclick = saveRun;
  $("apply").onclick = applySettings;
  $("play").onclick = () => control("play");
  $("pause").onclick = () => control("pause");
  $("step").onclick = () => control("step", { steps: 1 });
  $("reset").onclick = () => control("reset");
  $("speed").onchange = () => state.playing && control("play");
  $("world").onclick = (event) => {
    const agent = nearestAgent($("world"), state.frame, event);
    state.follow = agent;
    pollOnce();
  };
}

// Helpers for the browser test (positions on the screen; the test then drags with real
// pointer events).
function testHooks() {
  const screen = (ws, x, y) => Blockly.utils.svgMath.wsToScreenCoordinates(
    ws, new Blockly.utils.Coordinate(x, y));
  window.studio = {
    workspace: () => workspace,
    flyoutBlock(type) {
      const flyout = workspace.getToolbox().getFlyout();
      flyout.scrollToStart();
      Blockly.renderManagement.triggerQueuedRenders(flyout.getWorkspace());
      const block = flyout.getWorkspace().getTopBlocks(false).find((b) => b.type === type);
      const c = block.previousConnection;
      const p = screen(flyout.getWorkspace(), c.x, c.y);
      return { x: p.x, y: p.y };
    },
    newest(type) {
      const ids = state.created.filter((id) => workspace.getBlockById(id)?.type === type);
      return ids[ids.length - 1];
    },
    dropPoint(id) {
      Blockly.renderManagement.triggerQueuedRenders(workspace);
      const block = id ? workspace.getBlockById(id) : workspace.getBlocksByType(ROOT, false)[0];
      const input = block.getInput("CHILDREN") || block.getInput("ROOT");
      let connection = input.connection;
      const stack = block.getInputTargetBlock(input.name);
      if (stack) connection = stack.lastConnectionInStack(true) || connection;
      const p = screen(workspace, connection.x, connection.y);
      return { x: p.x, y: p.y };
    },
    // The dragged block's previous connection, on the screen.
    dragged() {
      const block = Blockly.common.getSelected();
      if (!block || !workspace.isDragging() || !block.getRelativeToSurfaceXY) return null;
      const xy = block.getRelativeToSurfaceXY();
      const offset = block.previousConnection.getOffsetInBlock();
      const p = screen(workspace, xy.x + offset.x, xy.y + offset.y);
      return { x: p.x, y: p.y };
    },
    tree: () => treeOf(workspace).tree,
    // The middle of a block's name field, on the screen (a click there edits the name).
    nameField(id) {
      Blockly.renderManagement.triggerQueuedRenders(workspace);
      const box = workspace.getBlockById(id).getField(NAME).getSvgRoot().getBoundingClientRect();
      return { x: box.left + box.width / 2, y: box.top + box.height / 2 };
    },
    name: (id) => workspace.getBlockById(id).getFieldValue(NAME),
    // A point on a block's type label, on the screen (a click there selects the block).
    blockPoint(id) {
      Blockly.renderManagement.triggerQueuedRenders(workspace);
      const box = workspace.getBlockById(id).getSvgRoot().getBoundingClientRect();
      return { x: box.left + 8, y: box.top + 8 };
    },
    agentPoint(i) {
      const canvas = $("world");
      const p = agentPixel(canvas, state.frame, i);
      const box = canvas.getBoundingClientRect();
      return { x: box.left + p.x * (box.width / canvas.width), y: box.top + p.y * (box.height / canvas.height) };
    },
    iteration: () => state.frame && state.frame.iteration,
    // What the last frame drew: drones, event diamonds, message lines, banner, measures.
    drawing: () => state.drawing,
    // The colour drawn at world point (x, y) of the map, as [r, g, b, a].
    pixel(x, y) {
      const canvas = $("world");
      const p = worldPixel(canvas, state.frame, x, y);
      return [...canvas.getContext("2d").getImageData(Math.round(p.x), Math.round(p.y), 1, 1).data];
    },
    framesDrawn: () => state.drawn || 0,
    profile: () => ({ ...profile }),
    openCategory() {
      const toolbox = workspace.getToolbox();
      return toolbox.getFlyout().isVisible() ? toolbox.getSelectedItem()?.getId() : null;
    },
    warning(id) {
      const icon = workspace.getBlockById(id).getIcon(Blockly.icons.IconType.WARNING);
      return icon ? icon.getText() : null;
    },
    runnable: () => state.ok,
    offer: () => $("offer").textContent,
    // Whether a check of the tree is pending or under way (it may move blocks: warnings).
    busy: () => checkTimer !== null || state.checking,
  };
}

async function main() {
  state.info = await api("/api/info");
  buildSettings(state.info.schema);
  startEditor(state.info);
  wire();
  testHooks();
  pollLoop();
}

main().catch((error) => say(error.message, "error"));
