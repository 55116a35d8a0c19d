// Screenshot of Foxglove Studio's web app on one MCAP file with one layout.
//
//   node shot.mjs TRIAL.mcap LAYOUT.json OUT.png TIME_RFC3339 [WIDTH HEIGHT SETTLE_S]
//
// Foxglove's web app is not on npm as a site, but @foxglove/studio-base 1.48.0 (MPL-2.0,
// the newest version on npm) ships the whole app prebuilt in assets/: a webpack UMD
// bundle with React 17 as an external (its package.json lists no dependencies). This serves
// that bundle, a page that mounts its <App> with an in-memory layout store holding
// LAYOUT, and TRIAL (with HTTP range requests, as Foxglove's "remote file" source reads
// it); opens the page in headless Chromium (Debian's `chromium`, software WebGL;
// CHROMIUM overrides the path) at TIME, lets it load and draw for SETTLE_S seconds,
// closes the data-source sidebar and saves the window. Run by
// scripts/foxglove_screenshot.py; needs Node 18+.
import { createReadStream, readFileSync, statSync } from "node:fs";
import { createServer } from "node:http";
import { createRequire } from "node:module";
import { dirname, extname, join, resolve } from "node:path";
import puppeteer from "puppeteer-core";

const [trial, layoutPath, out, time, width = "1600", height = "1000", settle = "15"] =
  process.argv.slice(2);
if (!time) {
  console.error("usage: node shot.mjs TRIAL.mcap LAYOUT.json OUT.png TIME_RFC3339 [W H SETTLE_S]");
  process.exit(2);
}
const require = createRequire(import.meta.url);
const assets = join(dirname(require.resolve("@foxglove/studio-base/package.json")), "assets");
const reactUmd = require.resolve("react/umd/react.production.min.js");
const reactDomUmd = require.resolve("react-dom/umd/react-dom.production.min.js");
const layout = JSON.parse(readFileSync(layoutPath, "utf8"));

const page = `<!doctype html>
<html><head><meta charset="utf-8"><title>Foxglove</title>
<style>html,body,#root{margin:0;height:100%;overflow:hidden}</style></head>
<body><div id="root"></div>
<script src="/react.js"></script><script src="/react-dom.js"></script>
<script>window.react = window.React; window["react-dom"] = window.ReactDOM;</script>
<script src="/studio/index.js"></script>
<script>
// Start with the panels' first-use tooltips already seen and the sidebars closed (the
// data-source sidebar opens anyway when a source is given in the URL).
localStorage.setItem("fox.workspace", JSON.stringify({ version: 0, state: {
  sidebarItem: undefined, leftSidebarOpen: false, rightSidebarOpen: false } }));
localStorage.setItem("studio.profile-data", JSON.stringify({
  onboarding: { settingsTooltipShownForPanelTypes: ["3D", "Plot"] } }));
const studio = window;  // the UMD bundle puts its exports on the global object
const LAYOUT = ${JSON.stringify(layout)};
const now = new Date().toISOString();
const layouts = new Map([["dresslog", {
  id: "dresslog", name: "dresslog", permission: "CREATOR_WRITE",
  baseline: { data: LAYOUT, savedAt: now }, working: undefined, syncInfo: undefined,
}]]);
const layoutStorage = {
  list: async () => [...layouts.values()],
  get: async (_ns, id) => layouts.get(id),
  put: async (_ns, l) => { layouts.set(l.id, l); return l; },
  delete: async (_ns, id) => { layouts.delete(id); },
  importLayouts: async () => {},
};
const config = new Map([["telemetry.telemetryEnabled", false], ["telemetry.crashReportingEnabled", false]]);
const appConfiguration = {
  get: (k) => config.get(k),
  set: async (k, v) => { config.set(k, v); },
  addChangeListener: () => {},
  removeChangeListener: () => {},
};
const app = React.createElement(studio.App, {
  deepLinks: [window.location.href],
  appConfiguration,
  dataSources: [new studio.RemoteDataSourceFactory()],
  layoutStorage,
  extensionLoaders: [],
  enableGlobalCss: true,
});
ReactDOM.render(app, document.getElementById("root"));
</script></body></html>`;

const types = { ".js": "text/javascript", ".wasm": "application/wasm", ".png": "image/png",
  ".ttf": "font/ttf", ".html": "text/html", ".mcap": "application/octet-stream" };

function sendFile(req, res, path) {
  let size;
  try { size = statSync(path).size; } catch { res.writeHead(404).end(); return; }
  const headers = { "Content-Type": types[extname(path)] ?? "application/octet-stream",
    "Accept-Ranges": "bytes", "Access-Control-Allow-Origin": "*" };
  const range = /^bytes=(\d+)-(\d*)$/.exec(req.headers.range ?? "");
  if (range) {
    const start = Number(range[1]);
    const end = range[2] ? Math.min(Number(range[2]), size - 1) : size - 1;
    res.writeHead(206, { ...headers, "Content-Range": `bytes ${start}-${end}/${size}`,
      "Content-Length": end - start + 1 });
    createReadStream(path, { start, end }).pipe(res);
  } else {
    res.writeHead(200, { ...headers, "Content-Length": size });
    createReadStream(path).pipe(res);
  }
}

const server = createServer((req, res) => {
  const url = new URL(req.url, "http://localhost");
  if (url.pathname === "/favicon.ico") {
    res.writeHead(204).end();
  } else if (url.pathname === "/") {
    res.writeHead(200, { "Content-Type": "text/html" }).end(page);
  } else if (url.pathname === "/react.js") {
    sendFile(req, res, reactUmd);
  } else if (url.pathname === "/react-dom.js") {
    sendFile(req, res, reactDomUmd);
  } else if (url.pathname === "/trial.mcap") {
    sendFile(req, res, resolve(trial));
  } else if (url.pathname.startsWith("/studio/")) {
    const rel = url.pathname.slice("/studio/".length);
    if (rel.includes("..")) { res.writeHead(400).end(); return; }
    sendFile(req, res, join(assets, rel));
  } else {
    res.writeHead(404).end();
  }
});
await new Promise((ok) => server.listen(0, "127.0.0.1", ok));
const base = `http://127.0.0.1:${server.address().port}`;

const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    `--window-size=${width},${height}`],
  defaultViewport: { width: Number(width), height: Number(height) },
});
try {
  const tab = await browser.newPage();
  tab.on("console", (m) => { if (m.type() === "error") console.error("page:", m.text()); });
  tab.on("response", (r) => { if (r.status() >= 400) console.error("page: HTTP", r.status(), r.url()); });
  tab.on("pageerror", (e) => console.error("page error:", e.message));
  const params = new URLSearchParams({ ds: "remote-file", "ds.url": `${base}/trial.mcap`,
    layoutId: "dresslog", time });
  const sleep = (s) => new Promise((ok) => setTimeout(ok, s * 1000));
  await tab.goto(`${base}/?${params}`, { waitUntil: "load" });
  await sleep(Number(settle));
  await tab.click('[data-sidebar-key="connection"]');  // close the data-source sidebar
  await sleep(3);
  await tab.screenshot({ path: out });
  console.log(`${out}: ${width}x${height} at ${time}`);
} finally {
  await browser.close();
  server.close();
}
