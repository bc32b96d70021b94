// Bundles the viewer page: src/main.ts and its packages into one ES module, plus static/ as is.
// node build.mjs [--out DIR] [--modules NODE_MODULES_DIR]
// The CMake target `web` passes both (node_modules in the build folder); without them it uses
// web/node_modules and web/dist.
import { cpSync, mkdirSync } from "node:fs";
import { createRequire } from "node:module";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const arg = (name, fallback) => {
  const i = process.argv.indexOf(name);
  return i > 0 && process.argv[i + 1] ? resolve(process.argv[i + 1]) : fallback;
};
const out = arg("--out", join(here, "dist"));
const modules = arg("--modules", join(here, "node_modules"));
// esbuild from that folder, not from beside this file: the build folder holds the packages.
const { build } = createRequire(join(modules, "package.json"))("esbuild");

mkdirSync(out, { recursive: true });
cpSync(join(here, "static"), out, { recursive: true });
await build({
  entryPoints: [join(here, "src", "main.ts")],
  outfile: join(out, "viewer.js"),
  bundle: true,
  format: "esm",
  target: "es2022",
  minify: true,
  sourcemap: true,
  nodePaths: [modules],
  logLevel: "warning",
});
