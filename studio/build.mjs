// npm run build: bundle src/main.js (with Blockly) into the package's studio/static/, and
// copy Blockly's media there, so the installed package serves everything itself.
import { build } from "esbuild";
import { cpSync, mkdirSync, rmSync } from "node:fs";

const out = new URL("../src/pyautonomousagent/studio/static/", import.meta.url);
rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });
await build({
  entryPoints: ["src/main.js"],
  bundle: true,
  minify: true,
  format: "iife",
  target: "es2020",
  outfile: new URL("studio.js", out).pathname,
  legalComments: "linked",
});
cpSync("node_modules/blockly/media", new URL("media", out).pathname, { recursive: true });
console.log(`built ${out.pathname}`);
