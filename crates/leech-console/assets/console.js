"use strict";
// The operator's page: draws what the server sends and asks it for
// commands. The server judges every request; the page only greys out what
// it already knows the server would refuse, and shows why.
(() => {
  const $ = (id) => document.getElementById(id);
  const SVG = "http://www.w3.org/2000/svg";
  const token = new URLSearchParams(location.search).get("token");
  const wsUrl = (location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws" +
    (token ? "?token=" + encodeURIComponent(token) : "");

  let ws = null;
  let hello = null;
  let state = null;
  let plan = null;
  let reach = null;
  let workspaceShown = false;
  let dragging = [false, false, false];
  // Measured by the browser tests: states received and bodies drawn.
  const stats = window.consoleStats = { states: 0, drawn: 0, drawnAt: [], lastBodyKey: "", lastDeviceTime: null };

  const log = (text, error) => {
    const li = document.createElement("li");
    li.textContent = new Date().toLocaleTimeString() + " " + text;
    if (error) li.className = "error";
    $("log").prepend(li);
    while ($("log").children.length > 30) $("log").lastChild.remove();
  };
  const send = (msg) => {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(msg));
  };
  const drives = () => hello && state && state.driver === hello.tab;
  const mm = (m) => (m * 1e3).toFixed(1);

  // --- drawing ------------------------------------------------------------
  const pt = (p) => (p[0] * 1e3).toFixed(2) + "," + (-p[1] * 1e3).toFixed(2);
  let unit = 1; // one screen pixel in drawing units (mm), roughly
  const el = (name, attrs) => {
    const e = document.createElementNS(SVG, name);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    return e;
  };
  function drawSeries(group, series, faded) {
    for (const s of series) {
      const pts = s.points_m.map(pt).join(" ");
      const width = { thick: 4, line_and_dots: 2, line: 1.2, dashed: 1.2, arrow: 1.5 }[s.style] || 1;
      const common = { stroke: s.color, "stroke-width": width * unit, fill: "none", opacity: faded ? 0.45 : 1 };
      if (s.style === "dots") {
        for (const p of s.points_m) group.append(el("circle", { cx: p[0] * 1e3, cy: -p[1] * 1e3, r: 1.5 * unit, fill: s.color }));
        continue;
      }
      if (s.style === "area") {
        group.append(el("polygon", { points: pts, fill: s.color, "fill-opacity": 0.15, stroke: s.color }));
        continue;
      }
      const line = el("polyline", Object.assign({ points: pts }, common));
      if (s.style === "dashed") line.setAttribute("stroke-dasharray", 4 * unit + " " + 3 * unit);
      if (s.style === "arrow") line.setAttribute("marker-end", "url(#arrow)");
      line.dataset.label = s.label;
      group.append(line);
      if (s.style === "line_and_dots") {
        for (const p of s.points_m) group.append(el("circle", { cx: p[0] * 1e3, cy: -p[1] * 1e3, r: 1.2 * unit, fill: s.color }));
      }
    }
  }
  function drawScene() {
    const [x0, y0, x1, y1] = hello.view_m;
    const svg = $("drawing");
    svg.setAttribute("viewBox", [x0 * 1e3, -y1 * 1e3, (x1 - x0) * 1e3, (y1 - y0) * 1e3].join(" "));
    unit = ((x1 - x0) * 1e3) / Math.max(svg.clientWidth || 800, 300);
    const defs = el("defs", {});
    const marker = el("marker", { id: "arrow", viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 6, markerHeight: 6, orient: "auto-start-reverse" });
    marker.append(el("path", { d: "M0,0 L10,5 L0,10 z", fill: "black" }));
    defs.append(marker);
    svg.prepend(defs);
    const solids = $("solids");
    solids.replaceChildren();
    for (const poly of hello.scene.solids) {
      solids.append(el("polygon", { points: poly.map(pt).join(" "), fill: "#cfd8dc", stroke: "#78909c", "stroke-width": unit }));
    }
    drawGoal(hello.goal);
  }
  function drawGoal(goal) {
    const g = $("goal");
    g.replaceChildren();
    if (!goal) return;
    g.append(el("circle", { cx: goal.point_m[0] * 1e3, cy: -goal.point_m[1] * 1e3, r: goal.tolerance_m * 1e3,
      fill: "none", stroke: "#cc0000", "stroke-width": 1.5 * unit, "stroke-dasharray": 4 * unit }));
  }
  function drawBody(group, body, faded) {
    group.replaceChildren();
    if (!body) return;
    drawSeries(group, body.series, faded);
  }

  // --- controls -------------------------------------------------------------
  function buildControls() {
    const tubes = $("tubes");
    const [lo, hi] = [hello.robot.tube_length_min_m, hello.robot.tube_length_max_m];
    for (let i = 0; i < 3; i++) {
      const tr = document.createElement("tr");
      tr.innerHTML = `<th>L${i + 1}</th><td><input type="range" id="slider-${i}" min="${lo * 1e3}" max="${hi * 1e3}" step="0.5"> <output id="set-${i}"></output></td>` +
        `<td id="measured-${i}"></td><td id="commanded-${i}"></td><td id="duty-${i}"></td>` +
        `<td><button id="jog-minus-${i}">-</button><button id="jog-plus-${i}">+</button></td>`;
      tubes.append(tr);
      const slider = $("slider-" + i);
      slider.addEventListener("pointerdown", () => { dragging[i] = true; });
      slider.addEventListener("pointerup", () => { dragging[i] = false; });
      slider.addEventListener("input", () => { $("set-" + i).textContent = slider.value; sendLengthsSoon(); });
      slider.addEventListener("change", () => { dragging[i] = false; sendLengths(); });
      $("jog-minus-" + i).onclick = () => jog(i, -1);
      $("jog-plus-" + i).onclick = () => jog(i, 1);
    }
    const cups = $("cups");
    for (const [i, cup] of ["rear", "front"].entries()) {
      const tr = document.createElement("tr");
      tr.innerHTML = `<th>${cup}</th><td><label><input type="checkbox" id="pump-${cup}"> on</label></td>` +
        `<td id="holds-${i}"></td><td id="vacuum-${i}"></td><td id="sf-${i}"></td><td id="flush-${i}"></td>`;
      cups.append(tr);
      $("pump-" + cup).addEventListener("change", (e) => {
        const on = e.target.checked;
        // Shown as the robot reports it until the server answers.
        e.target.checked = !on;
        send({ type: "pump", cup, on });
      });
    }
    const phases = $("phases");
    for (const phase of hello.phases) {
      const span = document.createElement("span");
      span.innerHTML = `<button id="phase-${phase}">${phase.replace("_", " ")}</button><span class="reason" id="reason-${phase}"></span>`;
      phases.append(span);
      $("phase-" + phase).onclick = () => {
        const msg = { type: "stride", phase };
        if (phase === "push" || phase === "pull") msg.lengths_m = [0, 1].map((i) => $("slider-" + i).value / 1e3);
        send(msg);
      };
    }
    for (const name of hello.scenarios) {
      const option = document.createElement("option");
      option.value = option.textContent = name;
      $("scenario").append(option);
    }
    if (hello.goal) {
      $("goal-x").value = hello.goal.point_m[0];
      $("goal-y").value = hello.goal.point_m[1];
      $("goal-tol").value = hello.goal.tolerance_m;
    }
  }
  let lengthsTimer = null;
  function sendLengths() {
    clearTimeout(lengthsTimer);
    lengthsTimer = null;
    send({ type: "set_lengths", lengths_m: [0, 1, 2].map((i) => $("slider-" + i).value / 1e3) });
  }
  // A drag sends at most every 40 ms: the latest position wins.
  function sendLengthsSoon() {
    if (!lengthsTimer) lengthsTimer = setTimeout(sendLengths, 40);
  }
  function jog(i, sign, times) {
    const step = Number($("jog-step").value) * (times || 1);
    send({ type: "jog", tube: i + 1, delta_mm: sign * step });
  }

  $("stop").onclick = () => send({ type: "stop" });
  $("control").onclick = () => send({ type: drives() ? "release_control" : "take_control" });
  $("reach-go").onclick = () => {
    if (reach && reach.lengths_m) send({ type: "set_lengths", lengths_m: [reach.lengths_m[0], reach.lengths_m[1], reach.lengths_m[1]] });
  };
  $("workspace-toggle").onclick = () => {
    workspaceShown = !workspaceShown;
    $("workspace-toggle").textContent = workspaceShown ? "Hide workspace" : "Show workspace";
    if (workspaceShown) send({ type: "workspace" });
    else $("workspace").replaceChildren();
  };
  $("plan").onclick = () => {
    const scenario = $("scenario").value;
    send(scenario ? { type: "plan", scenario } :
      { type: "plan", goal_m: [Number($("goal-x").value), Number($("goal-y").value)], tolerance_m: Number($("goal-tol").value) });
    $("plan-info").textContent = "planning...";
  };
  $("plan-play").onclick = () => playPlan();
  $("plan-step").onclick = () => send({ type: "execute", mode: "step" });
  $("plan-all").onclick = () => send({ type: "execute", mode: "all" });
  $("drawing").addEventListener("click", (e) => {
    const svg = $("drawing");
    const m = svg.getScreenCTM();
    if (!m) return;
    const p = new DOMPoint(e.clientX, e.clientY).matrixTransform(m.inverse());
    const point = [p.x / 1e3, -p.y / 1e3];
    send({ type: "reach", point_m: point });
    $("reach-info").textContent = "solving for (" + mm(point[0]) + ", " + mm(point[1]) + ") mm...";
  });
  document.addEventListener("keydown", (e) => {
    if (e.key === "Escape") { send({ type: "stop" }); e.preventDefault(); return; }
    if (e.target.tagName === "INPUT" && e.target.type === "number") return;
    const keys = { q: [0, 1], a: [0, -1], w: [1, 1], s: [1, -1], e: [2, 1], d: [2, -1] };
    const k = keys[e.key.toLowerCase()];
    if (k) { jog(k[0], k[1], e.shiftKey ? 5 : 1); e.preventDefault(); }
  });

  let playing = null;
  function playPlan() {
    if (!plan || !plan.steps.length) return;
    clearInterval(playing);
    let i = 0;
    playing = setInterval(() => {
      if (i >= plan.steps.length) {
        clearInterval(playing);
        $("preview").replaceChildren();
        $("caption").textContent = "";
        return;
      }
      drawBody($("preview"), plan.steps[i].body, true);
      $("caption").textContent = plan.steps[i].caption;
      i++;
    }, 600);
  }

  // --- state --------------------------------------------------------------
  function showState(s) {
    state = s;
    stats.states++;
    const mine = drives();
    $("control").textContent = mine ? "Release control" : "Take control";
    $("control-state").textContent = mine ? "you drive" : s.driver ? `tab ${s.driver} drives (you watch)` : "nobody drives";
    const body = s.prediction.body;
    const key = body ? body.lengths_m.join(",") + JSON.stringify(body.cups.map((c) => c.holds)) : "none";
    if (key !== stats.lastBodyKey) {
      drawBody($("body"), body, false);
      stats.lastBodyKey = key;
    }
    // The drawing is brought up to date with each new telemetry report (the
    // body is redrawn when the model's body changed): counted per report,
    // not per state message, so a frozen telemetry counts nothing.
    const deviceTime = s.telemetry ? s.telemetry.device_time_s : null;
    if (deviceTime !== null && deviceTime !== stats.lastDeviceTime) {
      stats.lastDeviceTime = deviceTime;
      stats.drawn++;
      stats.drawnAt.push(performance.now());
      if (stats.drawnAt.length > 200) stats.drawnAt.shift();
    }
    $("body").dataset.lengths = body ? body.lengths_m.map((l) => l.toFixed(5)).join(",") : "";
    // The tables are read by a person: 10 times a second is plenty, and
    // leaves the machine's time to the drawing and the robot's link.
    const now = performance.now();
    if (now - (showState.tablesAt || 0) < 100 && !showState.force) return;
    showState.tablesAt = now;
    showState.force = false;
    const t = s.telemetry;
    for (let i = 0; i < 3; i++) {
      $("measured-" + i).textContent = t ? mm(t.lengths_m[i]) : "-";
      $("commanded-" + i).textContent = s.commanded_m ? mm(s.commanded_m[i]) : "stopped";
      $("duty-" + i).textContent = t ? t.duty_permille[i] + (t.moving[i] ? " ‰ moving" : " ‰") : "-";
      const slider = $("slider-" + i);
      if (!dragging[i] && !lengthsTimer && document.activeElement !== slider) {
        const v = s.commanded_m ? s.commanded_m[i] : t ? t.lengths_m[i] : null;
        if (v !== null) { slider.value = v * 1e3; $("set-" + i).textContent = (v * 1e3).toFixed(1); }
      }
      slider.disabled = !mine;
      $("jog-minus-" + i).disabled = !mine;
      $("jog-plus-" + i).disabled = !mine;
    }
    for (const [i, cup] of ["rear", "front"].entries()) {
      const c = body ? body.cups[i] : null;
      $("pump-" + cup).checked = t ? t.pumps_on[i] : false;
      $("pump-" + cup).disabled = !mine;
      $("holds-" + i).textContent = t ? (t.holding[i] ? "holds" : "free") : "-";
      $("vacuum-" + i).textContent = t && t.vacuum_kpa[i] !== null ? t.vacuum_kpa[i].toFixed(1) + " kPa" : "-";
      $("sf-" + i).textContent = c && c.holds ? (c.safety_factor === null ? "unloaded" : c.safety_factor.toFixed(2)) : "-";
      $("flush-" + i).textContent = c ? (c.flush ? "flush" : "no") : "-";
    }
    for (const p of s.phases) {
      const b = $("phase-" + p.phase);
      if (!b) continue;
      const reason = !mine ? "take control to drive" : p.reason;
      b.disabled = !mine || !p.allowed;
      $("reason-" + p.phase).textContent = reason || "";
    }
    const running = s.run.busy;
    $("plan-step").disabled = !mine || running || !plan || plan.status !== "reached";
    $("plan-all").disabled = $("plan-step").disabled;
    $("run-info").textContent = (running ? "running " + s.run.what : "") +
      (s.run.steps ? ` (step ${s.run.next_step} of ${s.run.steps} done)` : "") + (s.run.error ? " last run: " + s.run.error : "");
    const h = s.link;
    const rows = [
      ["connected", h.connected ? "yes" : "no"],
      ["latency", h.latency_ms === null ? "-" : h.latency_ms.toFixed(2) + " ms (mean " + (h.mean_latency_ms || 0).toFixed(2) + ")"],
      ["sent / retries / gave up", `${h.sent} / ${h.retries} / ${h.give_ups}`],
      ["CRC errors (host / device)", `${h.bad_crc} / ${t ? t.device_bad_crc : "-"}`],
      ["bad frames (host / device)", `${h.bad_frames} / ${t ? t.device_bad_frames : "-"}`],
      ["faults", t ? t.faults : "-"],
      ["telemetry age", t ? t.age_ms.toFixed(0) + " ms" : "-"],
      ["tabs open", s.tabs],
    ];
    $("health").innerHTML = rows.map(([k, v]) => `<tr><th>${k}</th><td>${v}</td></tr>`).join("");
    if (s.notices.length && s.notices[s.notices.length - 1] !== showState.lastNotice) {
      showState.lastNotice = s.notices[s.notices.length - 1];
      log(showState.lastNotice, true);
    }
  }

  function onMessage(msg) {
    if (msg.type !== "state") showState.force = true;
    switch (msg.type) {
      case "hello":
        hello = msg;
        $("source").textContent = msg.robot.name + " on " + msg.scene.name + " (" + msg.source + ")";
        drawScene();
        buildControls();
        break;
      case "state":
        showState(msg);
        break;
      case "error":
        log(`refused ${msg.request}: ${msg.field} = ${msg.value}: ${msg.message} (allowed: ${msg.allowed})`, true);
        if (msg.request === "pump") $("pump-refusal").textContent = msg.message + " (allowed: " + msg.allowed + ")";
        if (msg.request === "plan" || msg.request === "execute") $("plan-info").textContent = msg.message;
        break;
      case "ok":
        if (msg.request === "pump") $("pump-refusal").textContent = "";
        log("done: " + msg.request);
        break;
      case "reach": {
        reach = msg;
        drawBody($("preview"), msg.body, true);
        const marks = $("marks");
        marks.replaceChildren();
        if (msg.surface_m) marks.append(el("circle", { cx: msg.surface_m[0] * 1e3, cy: -msg.surface_m[1] * 1e3, r: 3 * unit, fill: "#cc0000" }));
        $("reach-info").textContent = msg.status === "refused" ? msg.reason :
          `${msg.status}: LA ${mm(msg.lengths_m[0])} mm, LB ${mm(msg.lengths_m[1])} mm, endpoint off by ${mm(msg.error_m)} mm` +
          (msg.body ? ", front cup " + (msg.body.cups[1].flush ? "flush" : "not flush") : ", " + msg.reason);
        $("reach-go").disabled = !drives() || msg.status === "refused";
        break;
      }
      case "plan":
        plan = msg;
        drawGoal(msg.goal || hello.goal);
        $("plan-info").textContent = msg.status === "reached" ?
          `reached in ${msg.strides} strides, ${msg.steps.length} steps, about ${msg.duration_s.toFixed(0)} s of motion` :
          `${msg.status}: ${msg.reason || ""}`;
        $("plan-play").disabled = !msg.steps.length;
        if (msg.steps.length) playPlan();
        break;
      case "workspace": {
        const g = $("workspace");
        g.replaceChildren();
        for (const p of msg.points_m) g.append(el("circle", { cx: p[0] * 1e3, cy: -p[1] * 1e3, r: 1.2 * unit, fill: "#90caf9" }));
        break;
      }
      default:
        break;
    }
  }

  function connect() {
    ws = new WebSocket(wsUrl);
    ws.onopen = () => { $("connection").textContent = "online"; $("connection").className = "good"; };
    ws.onclose = () => {
      $("connection").textContent = "offline";
      $("connection").className = "bad";
      // The server may be restarting: try again, the page rebuilt from its hello.
      setTimeout(() => location.reload(), 2000);
    };
    ws.onmessage = (e) => {
      let msg;
      try { msg = JSON.parse(e.data); } catch (err) { return; }
      onMessage(msg);
    };
  }
  connect();
  // Control is a lease the server ends after 10 s without a word from this
  // tab: while it drives, a ping every 2 s keeps it (a hung tab stops them).
  setInterval(() => { if (drives()) send({ type: "ping" }); }, 2000);
})();
