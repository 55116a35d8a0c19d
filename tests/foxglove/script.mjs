// Run the Foxglove layout's user script as Foxglove does: transpiled from TypeScript, its
// default export called with each input message in turn.
//
//   node script.mjs LAYOUT.json EVENTS.json  ->  JSON on stdout: the script's inputs,
//   output topic and what it returned for each event ({topic, message}).
import { readFileSync, writeFileSync, mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import ts from "typescript";

const layout = JSON.parse(readFileSync(process.argv[2], "utf8"));
const events = JSON.parse(readFileSync(process.argv[3], "utf8"));
const outputs = {};
for (const [id, node] of Object.entries(layout.userNodes)) {
  const { outputText, diagnostics } = ts.transpileModule(node.sourceCode, {
    compilerOptions: { module: ts.ModuleKind.ESNext, target: ts.ScriptTarget.ES2022 },
    reportDiagnostics: true,
  });
  if (diagnostics.length) throw new Error(`${id}: ${diagnostics[0].messageText}`);
  const file = join(mkdtempSync(join(tmpdir(), "dresslog-script-")), `${id}.mjs`);
  writeFileSync(file, outputText);
  const script = await import(pathToFileURL(file));
  outputs[id] = {
    inputs: script.inputs,
    output: script.output,
    results: events.map((event) => script.default(event)),
  };
}
process.stdout.write(JSON.stringify(outputs));
