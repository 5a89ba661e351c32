// The console's page in Debian's Chromium against the simulated robot:
// the body drawn, a slider moving the robot and the drawing following, a
// pump switched, a refused release explained, the stop, a short plan.
// Measures the drawing's update rate and a slider move's latency to the
// drawn body, and saves screenshots. run.sh starts it; LEECH_BIN is the
// leech binary, SHOTS the screenshots' folder.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { spawn } from "node:child_process";
import { mkdtempSync, mkdirSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";

const BIN = process.env.LEECH_BIN;
const SHOTS = process.env.SHOTS || join(tmpdir(), "leech-console-shots");
const CHROMIUM = process.env.CHROMIUM || "/usr/bin/chromium";
const FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
  "--disable-sync", "--no-first-run"];

let server, url, context, page, profile;
const measured = {};

before(async () => {
  assert.ok(BIN, "LEECH_BIN names the leech binary");
  mkdirSync(SHOTS, { recursive: true });
  server = spawn(BIN, ["serve", "--listen", "127.0.0.1:0"], { stdio: ["ignore", "pipe", "inherit"] });
  url = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error("leech serve printed no URL in 60 s")), 60000);
    let text = "";
    server.stdout.on("data", (d) => {
      text += d;
      const m = text.match(/open (http:\/\/\S+)/);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    });
    server.on("exit", (code) => reject(new Error("leech serve exited with " + code)));
  });
  profile = mkdtempSync(join(tmpdir(), "leech-chromium-"));
  context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM, headless: true, args: FLAGS, viewport: { width: 1500, height: 950 },
  });
  page = context.pages()[0] || await context.newPage();
  await page.goto(url);
});

after(async () => {
  if (context) await context.close();
  if (server) server.kill();
  if (profile) rmSync(profile, { recursive: true, force: true });
  writeFileSync(join(SHOTS, "measurements.json"), JSON.stringify(measured, null, 2) + "\n");
});

const stateOf = () => page.evaluate(() => window.consoleStats);
const reason = (phase) => page.locator(`#reason-${phase}`).textContent();

test("the page draws the body and follows telemetry at 30 Hz or more", async () => {
  await page.waitForFunction(() => document.querySelectorAll("#body polyline").length > 3, null, { timeout: 30000 });
  await page.waitForFunction(() => document.getElementById("holds-0").textContent === "holds", null, { timeout: 30000 });
  await page.click("#control");
  await page.waitForFunction(() => document.getElementById("control").textContent === "Release control");
  const a = await stateOf();
  await page.waitForTimeout(2000);
  const b = await stateOf();
  // Drawings brought up to date with a new telemetry report, per second.
  const rate = (b.drawn - a.drawn) / 2;
  measured.drawing_updates_per_s = rate;
  assert.ok(rate >= 30, `the drawing was brought up to date with new telemetry ${rate} times a second`);
  await page.screenshot({ path: join(SHOTS, "console.png") });
});

// L1 at the start (mm, measured), where the front cup lies flush on the floor.
let startL1;

test("a slider moves the simulated robot and the drawing follows within 100 ms", async () => {
  await page.waitForFunction(() => Number(document.getElementById("measured-0").textContent) > 0, null, { timeout: 10000 });
  startL1 = Number(await page.locator("#measured-0").textContent());
  const target = Math.round(startL1 + 20);
  const latency = await page.evaluate(async (target) => {
    const slider = document.getElementById("slider-0");
    const body = document.getElementById("body");
    const before = body.dataset.lengths;
    const t0 = performance.now();
    slider.value = target;
    slider.dispatchEvent(new Event("input"));
    slider.dispatchEvent(new Event("change"));
    while (body.dataset.lengths === before) await new Promise((r) => requestAnimationFrame(r));
    return performance.now() - t0;
  }, target);
  measured.slider_to_drawn_body_ms = latency;
  assert.ok(latency < 100, `the drawn body changed ${latency} ms after the slider`);
  // The robot arrives (within the controller's 0.5 mm) and the drawn body with it.
  await page.waitForFunction((t) => {
    const l = document.getElementById("body").dataset.lengths.split(",").map(Number);
    const m = Number(document.getElementById("measured-0").textContent);
    return Math.abs(l[0] * 1e3 - t) < 1 && Math.abs(m - t) <= 0.6;
  }, target, { timeout: 10000 });
});

test("a pump switches, and a release that would drop the robot is refused with the reason", async () => {
  // A free cup's pump goes on only where the cup may attach: refused with
  // the interlock's reason while the front cup is off the floor...
  await page.click("#pump-front");
  await page.waitForFunction(() => document.getElementById("pump-refusal").textContent.length > 0, null, { timeout: 5000 });
  assert.match(await page.locator("#pump-refusal").textContent(), /flush/);
  assert.ok(!(await page.locator("#pump-front").isChecked()), "the front pump stays off");
  // ...and switched on once L1 is back where the front cup lies flush.
  await page.evaluate((t) => {
    const slider = document.getElementById("slider-0");
    slider.value = t;
    slider.dispatchEvent(new Event("change"));
  }, Math.round(startL1));
  await page.waitForFunction(() => !document.getElementById("phase-attach_front").disabled, null, { timeout: 15000 })
    .catch(async () => {
      throw new Error(`attach_front stays refused: ${await reason("attach_front")}; L1 ${await page.locator("#measured-0").textContent()} mm`);
    });
  await page.click("#pump-front");
  await page.waitForFunction(() => document.getElementById("pump-front").checked, null, { timeout: 5000 });
  await page.click("#pump-front");
  await page.waitForFunction(() => !document.getElementById("pump-front").checked, null, { timeout: 5000 });
  await page.click("#pump-rear");
  await page.waitForFunction(() => document.getElementById("pump-refusal").textContent.length > 0, null, { timeout: 5000 });
  const text = await page.locator("#pump-refusal").textContent();
  assert.match(text, /would fall/);
  assert.ok(await page.locator("#pump-rear").isChecked(), "the rear pump stays on");
  assert.ok(await page.locator("#phase-release_rear").isDisabled());
  assert.match(await reason("release_rear"), /would fall/);
  await page.screenshot({ path: join(SHOTS, "refused-release.png") });
});

test("Escape stops the motors", async () => {
  const l2 = Number(await page.locator("#measured-1").textContent());
  await page.evaluate((t) => {
    const slider = document.getElementById("slider-1");
    slider.value = t;
    slider.dispatchEvent(new Event("change"));
  }, Math.round(l2 + 60));
  await page.waitForFunction(() => document.getElementById("duty-1").textContent.includes("moving"), null, { timeout: 5000 });
  const pressed = Number(await page.locator("#measured-1").textContent());
  const t0 = await page.evaluate(() => performance.now());
  await page.locator("body").press("Escape");
  await page.waitForFunction(() => [0, 1, 2].every((i) => !document.getElementById("duty-" + i).textContent.includes("moving")),
    null, { timeout: 2000 });
  const shown = (await page.evaluate(() => performance.now())) - t0;
  measured.escape_to_stopped_shown_ms = shown;
  assert.equal(await page.locator("#commanded-1").textContent(), "stopped");
  // The tube is at rest where Escape caught it: at 20 mm/s a 200 ms stop
  // moves it 4 mm; the page's tables refresh every 100 ms.
  await page.waitForTimeout(300);
  const stopped = Number(await page.locator("#measured-1").textContent());
  assert.ok(Math.abs(stopped - pressed) < 4, `L2 went on from ${pressed} to ${stopped} mm after Escape`);
  assert.ok(shown < 500, `the page showed the motors stopped ${shown} ms after Escape`);
});

test("a click on the floor previews the body that puts the front cup there; the workspace overlays", async () => {
  // Where the floor is, 0.2 m ahead of the rear cup, on the screen.
  const at = await page.evaluate(() => {
    const svg = document.getElementById("drawing");
    const p = new DOMPoint(200, 0).matrixTransform(svg.getScreenCTM());
    return { x: p.x, y: p.y };
  });
  await page.mouse.click(at.x, at.y);
  await page.waitForFunction(() => /reached|unreachable|refused/.test(document.getElementById("reach-info").textContent),
    null, { timeout: 60000 });
  const info = await page.locator("#reach-info").textContent();
  assert.match(info, /^(reached|unreachable): LA \d/);
  assert.ok(await page.locator("#preview polyline").count() > 3, "the predicted body is drawn");
  assert.ok(!(await page.locator("#reach-go").isDisabled()), "Go is offered");
  await page.click("#workspace-toggle");
  await page.waitForFunction(() => document.querySelectorAll("#workspace circle").length > 100, null, { timeout: 60000 });
  await page.screenshot({ path: join(SHOTS, "reach-preview.png") });
  await page.click("#workspace-toggle");
});

test("a short plan is previewed and carried out", async () => {
  await page.fill("#goal-x", "0.1");
  await page.fill("#goal-y", "0");
  await page.fill("#goal-tol", "0.05");
  await page.click("#plan");
  await page.waitForFunction(() => /reached|impossible|stopped|refused/.test(document.getElementById("plan-info").textContent),
    null, { timeout: 120000 });
  assert.match(await page.locator("#plan-info").textContent(), /^reached/);
  await page.waitForFunction(() => document.getElementById("caption").textContent.length > 0, null, { timeout: 5000 });
  await page.screenshot({ path: join(SHOTS, "plan-preview.png") });
  await page.click("#plan-all");
  await page.waitForFunction(() => /running/.test(document.getElementById("run-info").textContent), null, { timeout: 5000 });
  await page.waitForFunction(() => !/running/.test(document.getElementById("run-info").textContent), null,
    { timeout: 120000 });
  const done = await page.locator("#run-info").textContent();
  await page.screenshot({ path: join(SHOTS, "plan-done.png") });
  assert.match(done, /step (\d+) of \1 done/);
  assert.doesNotMatch(done, /last run/);
});
