// The live pages' script (no framework, no build step). It sends the API key, when there is one, as a
// header with every request; the key comes from the page address's fragment (#key=KEY), which browsers
// never send to a server, and is kept for this tab in sessionStorage.
"use strict";

const KEY_STORE = "jarvis-api-key";
const RETRY_MS = 2000;

function apiKey() {
  const match = location.hash.match(/(?:^#|&)key=([^&]+)/);
  if (match) sessionStorage.setItem(KEY_STORE, decodeURIComponent(match[1]));
  return sessionStorage.getItem(KEY_STORE);
}

function authHeaders() {
  const key = apiKey();
  return key ? { Authorization: "Bearer " + key } : {};
}

function keyFragment() {
  const key = apiKey();
  return key ? "#key=" + encodeURIComponent(key) : "";
}

function element(tag, text, className) {
  const node = document.createElement(tag);
  if (text !== undefined && text !== null) node.textContent = String(text);
  if (className) node.className = className;
  return node;
}

function setStatus(text, kind) {
  const status = document.getElementById("status");
  status.textContent = text;
  status.className = "status " + (kind || "");
}

async function errorText(response) {
  try {
    const body = await response.json();
    return `${response.status} ${body.error}: ${body.detail}`;
  } catch (_) {
    return `HTTP ${response.status}`;
  }
}

// ---- the list of sessions ------------------------------------------------------------------------------

async function refreshList() {
  const response = await fetch("/v1/sessions", { headers: authHeaders() });
  if (!response.ok) {
    setStatus(await errorText(response), "error");
    return;
  }
  const ids = (await response.json()).session_ids;
  const rows = await Promise.all(ids.map(async (id) => {
    const one = await fetch(`/v1/sessions/${encodeURIComponent(id)}`, { headers: authHeaders() });
    return one.ok ? one.json() : null;
  }));
  const body = document.querySelector("#sessions tbody");
  body.replaceChildren();
  for (const session of rows) {
    if (session === null) continue; // deleted between the list and its read
    const row = element("tr");
    const link = element("a", session.session_id);
    link.href = `/v1/sessions/${encodeURIComponent(session.session_id)}/view${keyFragment()}`;
    const cell = element("td");
    cell.append(link);
    const plan = session.plan;
    const current = plan.subgoals[plan.pointer];
    row.append(cell, element("td", session.mode), element("td", session.step),
      element("td", current ? current.text : "—"), element("td", session.done ? "done" : "running"));
    body.append(row);
  }
  setStatus(`${ids.length} session(s), updated ${new Date().toLocaleTimeString()}`, "live");
}

function startList() {
  const tick = () => refreshList().catch((error) => setStatus(String(error), "error"));
  tick();
  setInterval(tick, 3000);
}

// ---- one session, live ----------------------------------------------------------------------------------

function render(view) {
  const session = view.session;
  const plan = session.plan;
  document.body.dataset.revision = view.revision;
  document.body.dataset.step = view.step;
  document.getElementById("summary").textContent =
    `${session.mode} · planner ${session.planner} · perception ${session.perception} · ` +
    `step ${session.step}${session.done ? " · done" : ""}`;

  const frame = document.getElementById("frame");
  const click = document.getElementById("click");
  const caption = document.getElementById("frame-caption");
  if (view.frame) {
    frame.src = "data:image/jpeg;base64," + view.frame.jpeg;
    const clicked = view.frame.x !== null && view.frame.y !== null;
    click.hidden = !clicked;
    if (clicked) {
      click.style.left = (100 * view.frame.x).toFixed(2) + "%";
      click.style.top = (100 * view.frame.y).toFixed(2) + "%";
    }
    caption.textContent = `step ${view.frame.step}: ${view.frame.action}` +
      (clicked ? ` at (${view.frame.x.toFixed(3)}, ${view.frame.y.toFixed(3)})` : "");
  } else {
    frame.removeAttribute("src");
    click.hidden = true;
    caption.textContent = view.step > 0 ? "the steps sent no RGB frame" : "no step yet";
  }
  document.getElementById("map").src = "data:image/png;base64," + view.map_png;

  const list = document.getElementById("plan");
  list.dataset.pointer = plan.pointer;
  list.replaceChildren(...plan.subgoals.map((subgoal, index) => element("li", subgoal.text,
    index < plan.pointer ? "done" : index === plan.pointer ? "current" : "")));
  if (plan.pointer >= plan.subgoals.length) list.append(element("li", "(plan finished)", "current"));
  document.getElementById("repairs").replaceChildren(...(plan.repair_log.length ? plan.repair_log.map(
    (event) => element("li", `${event.rule} (at ${event.index}): ${event.reason}`)) : [element("li", "none")]));

  document.getElementById("dialogue").replaceChildren(...(session.dialogue.length ? session.dialogue.map(
    (turn) => element("li", `${turn.speaker}: ${turn.text}`)) : [element("li", "none")]));

  const progress = view.progress;
  const facts = [
    ["subgoals done", `${progress.subgoals_done} of ${progress.subgoals}`],
    ["steps", progress.steps],
    ["failed actions (last trace lines)", progress.failed_actions_recent],
    ["state", progress.done ? "done" : "running"],
    ["SR / GC", progress.goal_conditions === null
      ? "not reported to the service (the harness scores them after the episode)"
      : JSON.stringify(progress.goal_conditions)],
  ];
  document.getElementById("progress").replaceChildren(...facts.flatMap(
    ([name, value]) => [element("dt", name), element("dd", value)]));

  const rows = view.trace.slice().reverse().map((entry) => {
    const row = element("tr");
    const verdict = entry.last_action === null ? "—"
      : `${entry.last_action}: ${entry.last_action_success === false ? "failed"
        : entry.last_action_success ? "ok" : "unknown"}`;
    row.append(element("td", entry.step), element("td", entry.action), element("td", entry.subgoal || "—"),
      element("td", entry.reason), element("td", verdict, entry.last_action_success === false ? "failed" : ""),
      element("td", (entry.events || []).join("; ")));
    return row;
  });
  document.querySelector("#trace tbody").replaceChildren(...rows);
}

// One server-sent event block ("id: ...\nevent: ...\ndata: ...") into its fields.
function parseEvent(block) {
  const event = { id: null, name: "message", data: "" };
  for (const line of block.split("\n")) {
    if (line.startsWith(":")) continue; // heartbeat comment
    const colon = line.indexOf(":");
    const field = colon < 0 ? line : line.slice(0, colon);
    const value = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
    if (field === "id") event.id = value;
    else if (field === "event") event.name = value;
    else if (field === "data") event.data += (event.data ? "\n" : "") + value;
  }
  return event;
}

// EventSource cannot send an Authorization header, so the stream is read with fetch; it reconnects with
// Last-Event-ID as EventSource would, and the service sends only what is newer than that.
async function follow(sessionId) {
  let lastId = null;
  for (;;) {
    const headers = authHeaders();
    if (lastId !== null) headers["Last-Event-ID"] = lastId;
    let response;
    try {
      response = await fetch(`/v1/sessions/${encodeURIComponent(sessionId)}/events`, { headers });
    } catch (error) {
      setStatus(`reconnecting (${error})…`, "");
      await new Promise((done) => setTimeout(done, RETRY_MS));
      continue;
    }
    if (!response.ok) {
      setStatus(await errorText(response), "error");
      if (response.status === 503 || response.status === 429) {
        await new Promise((done) => setTimeout(done, RETRY_MS));
        continue;
      }
      return; // 401, 404: reconnecting would not change the answer
    }
    setStatus("live", "live");
    const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
    let buffer = "";
    try {
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buffer += value;
        let end;
        while ((end = buffer.indexOf("\n\n")) >= 0) {
          const event = parseEvent(buffer.slice(0, end));
          buffer = buffer.slice(end + 2);
          if (event.name === "view") {
            render(JSON.parse(event.data));
            lastId = event.id;
          } else if (event.name === "gone") {
            setStatus("ended: " + JSON.parse(event.data).detail, "ended");
            return;
          } else if (event.name === "unavailable") {
            setStatus("the service's store did not answer; reconnecting…", "error");
          }
        }
      }
    } catch (error) {
      setStatus(`reconnecting (${error})…`, "");
    }
    await new Promise((done) => setTimeout(done, RETRY_MS));
  }
}

function startSession() {
  const match = location.pathname.match(/^\/v1\/sessions\/([^/]+)\/view$/);
  const sessionId = decodeURIComponent(match[1]);
  document.getElementById("session-id").textContent = sessionId;
  document.title = "JARVIS session " + sessionId;
  document.getElementById("back").href = "/v1/view" + keyFragment();
  follow(sessionId);
}

if (document.body.dataset.page === "sessions") startList();
else startSession();
