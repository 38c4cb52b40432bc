// Blocks made at run time from the server's palette (the registries), and the tree of
// blocks <-> the plain tree the server checks: {type, name, ports, children}.
import * as Blockly from "blockly/core";

export const ROOT = "bt_root";
const CONTROL_COLOUR = 210;
const DECORATOR_COLOUR = 160;
const CONDITION_COLOUR = 45;
const ACTION_COLOUR = 330;

/** The field on each node block that shows the followed agent's status and the count of
 * agents that have the node active. */
export const STATUS = "STATUS";
/** The field of each node block that holds the node's name (saved in the tree file). */
export const NAME = "NAME";

function statusField() {
  return new Blockly.FieldLabel("", "st-label");
}

/** Show ``status`` (success, failure, running, invalid) and ``active`` on ``block``,
 * without an undo step or a change event (it is no edit). */
export function showStatus(block, status, active) {
  const field = block.getField(STATUS);
  const text = `${status === "invalid" || !status ? "" : `● ${status}`} ${active ? `[${active}]` : ""}`;
  if (!field || field.getValue() === text.trim()) return;
  Blockly.Events.disable();
  try {
    field.setValue(text.trim());
    field.setClass(`st-label st-${status || "none"}`);
  } finally {
    Blockly.Events.enable();
  }
}

/** The Blockly block type of a node tag or leaf type. */
export function blockType(tag) {
  return `bt_${tag}`;
}

function nameField(name) {
  const field = new Blockly.FieldTextInput(name);
  field.setTooltip("the node's name (saved in the tree file; each node has its own)");
  return field;
}

function portField(block, name, hint) {
  block
    .appendDummyInput(`PORT_${name}`)
    .appendField(`${name}${hint ? ` (${hint})` : ""}`)
    .appendField(new Blockly.FieldTextInput(""), `P_${name}`);
}

/** Define one block type per control tag and per leaf of the palette. */
export function defineBlocks(palette) {
  Blockly.Blocks[ROOT] = {
    init() {
      this.appendDummyInput().appendField("Tree");
      this.appendStatementInput("ROOT").setCheck("node");
      this.setColour(0);
      this.setDeletable(false);
      this.setTooltip("the tree: put its root node here");
    },
  };
  for (const control of palette.controls) {
    Blockly.Blocks[blockType(control.type)] = {
      init() {
        const label = control.symbol ? `${control.symbol}  ${control.type}` : control.type;
        this.appendDummyInput().appendField(label).appendField(nameField(control.name), NAME)
          .appendField(statusField(), STATUS);
        for (const param of control.params) {
          portField(this, param.name, param.required ? "required" : "");
        }
        this.appendStatementInput("CHILDREN").setCheck("node");
        this.setPreviousStatement(true, "node");
        this.setNextStatement(true, "node");
        this.setColour(control.kind === "Decorator" ? DECORATOR_COLOUR : CONTROL_COLOUR);
        this.setTooltip(control.doc);
      },
    };
  }
  for (const leaf of palette.leaves) {
    Blockly.Blocks[blockType(leaf.type)] = {
      init() {
        this.appendDummyInput().appendField(leaf.type).appendField(nameField(leaf.name), NAME)
          .appendField(statusField(), STATUS);
        for (const port of leaf.ports) {
          portField(this, port.name, `default ${port.value ?? port.default}`);
        }
        this.setPreviousStatement(true, "node");
        this.setNextStatement(true, "node");
        this.setColour(leaf.type.startsWith("Condition") ? CONDITION_COLOUR : ACTION_COLOUR);
        const ports = leaf.ports.map((p) => `${p.name}: ${p.hint}; ${p.doc}`).join("\n");
        this.setTooltip(ports ? `${leaf.doc}\n${ports}` : leaf.doc);
      },
    };
  }
}

/** The toolbox: control nodes, decorators, the scenario's leaves, the general leaves. */
export function toolbox(palette) {
  const blocks = (list) => list.map((item) => ({ kind: "block", type: blockType(item.type) }));
  const category = (name, id, colour, list) => ({
    kind: "category", name, toolboxitemid: id, colour: String(colour), contents: blocks(list),
  });
  return {
    kind: "categoryToolbox",
    contents: [
      category("Control", "cat-control", CONTROL_COLOUR,
        palette.controls.filter((c) => c.kind !== "Decorator")),
      category("Decorators", "cat-decorators", DECORATOR_COLOUR,
        palette.controls.filter((c) => c.kind === "Decorator")),
      category("Mission leaves", "cat-mission", ACTION_COLOUR,
        palette.leaves.filter((l) => !l.general)),
      category("General leaves", "cat-general", CONDITION_COLOUR,
        palette.leaves.filter((l) => l.general)),
    ],
  };
}

function chain(first) {
  const out = [];
  for (let block = first; block; block = block.getNextBlock()) out.push(block);
  return out;
}

/** The tree under the root block: {tree, blocks (depth first), roots (how many)}. */
export function treeOf(workspace) {
  const root = workspace.getBlocksByType(ROOT, false)[0];
  const tops = root ? chain(root.getInputTargetBlock("ROOT")) : [];
  const order = [];
  const visit = (block) => {
    order.push(block);
    const name = block.getFieldValue(NAME).trim() || null;
    const ports = {};
    for (const input of block.inputList) {
      for (const field of input.fieldRow) {
        if (field.name && field.name.startsWith("P_")) ports[field.name.slice(2)] = field.getValue();
      }
    }
    const kids = block.getInput("CHILDREN") ? chain(block.getInputTargetBlock("CHILDREN")) : [];
    return {
      type: block.type.slice(3),
      name,
      ports,
      children: kids.map(visit),
    };
  };
  const tree = tops.length ? visit(tops[0]) : null;
  return { tree, blocks: order, roots: tops.length };
}

function stateOf(node) {
  const fields = {};
  for (const [key, value] of Object.entries(node.ports || {})) fields[`P_${key}`] = value;
  if (node.name) fields[NAME] = node.name;
  const state = { type: blockType(node.type), fields };
  const kids = node.children || [];
  if (kids.length) state.inputs = { CHILDREN: { block: stackOf(kids) } };
  return state;
}

function stackOf(nodes) {
  const states = nodes.map(stateOf);
  for (let i = states.length - 2; i >= 0; i--) states[i].next = { block: states[i + 1] };
  return states[0];
}

/** Give each of the blocks ``ids`` that shares its name with another block of
 * ``workspace`` a name of its own, as the file loader names unnamed nodes (``base_2``,
 * ``base_3``, ...): a new block starts with its type's name, a copy with its original's. */
export function uniqueNames(workspace, ids) {
  const fresh = new Set(ids);
  const taken = new Set();
  for (const block of workspace.getAllBlocks(false)) {
    if (!fresh.has(block.id) && block.getField(NAME)) taken.add(block.getFieldValue(NAME));
  }
  for (const id of ids) {
    const block = workspace.getBlockById(id);
    if (!block || !block.getField(NAME)) continue;
    const base = block.getFieldValue(NAME).replace(/_\d+$/, "") || block.type.slice(3);
    let name = block.getFieldValue(NAME);
    for (let n = 2; taken.has(name); n++) name = `${base}_${n}`;
    if (name !== block.getFieldValue(NAME)) block.setFieldValue(name, NAME);
    taken.add(name);
  }
}

/** Replace the workspace with the root block holding ``tree`` (null: empty). */
export function loadTree(workspace, tree) {
  workspace.clear();
  const root = { type: ROOT, x: 200, y: 20, deletable: false };
  if (tree) root.inputs = { ROOT: { block: stateOf(tree) } };
  Blockly.Events.disable();
  try {
    Blockly.serialization.blocks.append(root, workspace);
  } finally {
    Blockly.Events.enable();
  }
}
