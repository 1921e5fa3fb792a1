// Watch a live Foxglove WebSocket server (the recorder's) the way Foxglove's own app would, and check
// every message against the official Foxglove schemas.
// Usage: node tests/js/live_client.mjs --url ws://127.0.0.1:PORT --timeout-s N [--min-channels K]
//
// Connects with the official FoxgloveClient (@foxglove/ws-protocol) over `ws` (Node 20 has no global
// WebSocket), retrying until the deadline since the server may still be starting. It offers both
// subprotocol names: the foxglove SDK's server (Rust crate, 0.30) accepts only "foxglove.sdk.v1" and
// answers 400 to a client offering just "foxglove.websocket.v1"; Foxglove documents the two as the
// same protocol under a new name, and FoxgloveClient (>= 0.7.5) leaves the choice to the handshake.
// Subscribes to every channel as it is advertised; counts messages per channel. A message is invalid
// when its channel's schemaName is not an official Foxglove schema, its encoding is not "protobuf"
// (all our view channels are), the channel's advertised FileDescriptorSet disagrees with the
// official definition, or its bytes do not decode strictly as the official type (foxglove_defs.mjs).
// Finishes when at least K channels were advertised and every advertised channel has a valid
// message, or at the deadline. Prints
//   {"channels": {topic: {schemaName, encoding, messages, invalid}}, "complete": bool, "errors": [...]}
// and exits 0 iff complete with no invalid message, else 1 (2 for bad usage).

import wsProtocol from "@foxglove/ws-protocol"; // CommonJS build: its named exports are on the default
import WebSocket from "ws";
import { compareDescriptor, decodeOfficial } from "./foxglove_defs.mjs";

const { FoxgloveClient, StatusLevel } = wsProtocol;
const MAX_ERRORS = 10;
const RETRY_MS = 200;
const SUBPROTOCOLS = ["foxglove.sdk.v1", FoxgloveClient.SUPPORTED_SUBPROTOCOL]; // the latter is foxglove.websocket.v1

function parseArgs(argv) {
  const args = { url: undefined, timeoutS: undefined, minChannels: 1 };
  for (let i = 0; i < argv.length; i += 2) {
    const [flag, value] = [argv[i], argv[i + 1]];
    if (flag === "--url") args.url = value;
    else if (flag === "--timeout-s") args.timeoutS = Number(value);
    else if (flag === "--min-channels") args.minChannels = Number(value);
    else args.bad = true;
  }
  if (!args.url || !(args.timeoutS > 0) || !Number.isInteger(args.minChannels) || args.minChannels < 0 || args.bad) {
    process.stderr.write("usage: node live_client.mjs --url ws://HOST:PORT --timeout-s N [--min-channels K]\n");
    process.exit(2);
  }
  return args;
}

const { url, timeoutS, minChannels } = parseArgs(process.argv.slice(2));
const deadline = Date.now() + timeoutS * 1000;

const channels = {}; // topic -> {schemaName, encoding, messages, invalid} (the printed result)
const live = new Map(); // channel id -> {topic, schemaName, schemaError} for currently advertised channels
const bySubscription = new Map(); // subscription id -> channel id
const errors = [];
let errorCount = 0;
const note = (msg) => { errorCount++; if (errors.length < MAX_ERRORS) errors.push(msg); };

// Every topic ever advertised must have delivered a valid message: a channel the server withdrew
// (all of them, when the recorder ends) without delivering one does not count as done.
const isComplete = () =>
  Object.keys(channels).length >= minChannels &&
  Object.values(channels).every((c) => c.messages - c.invalid > 0);

let finished = false;
let current; // the FoxgloveClient of the connection attempt under way
function finish() {
  if (finished) return;
  finished = true;
  const complete = isComplete();
  const invalid = Object.values(channels).reduce((n, c) => n + c.invalid, 0);
  if (errorCount > errors.length) errors.push(`... and ${errorCount - errors.length} more`);
  process.stdout.write(JSON.stringify({ channels, complete, errors }) + "\n");
  // Say goodbye politely (a close frame), then exit whatever the socket does: an open socket or a
  // pending retry timer must not keep the process alive.
  current?.close();
  setTimeout(() => process.exit(complete && invalid === 0 ? 0 : 1), 100);
}
setTimeout(finish, Math.max(0, deadline - Date.now()));

function onAdvertise(client, advertised) {
  for (const ch of advertised) {
    // Re-advertising the same topic (e.g. a new channel id) adds to the same result entry.
    channels[ch.topic] ??= { schemaName: ch.schemaName, encoding: ch.encoding, messages: 0, invalid: 0 };
    let schemaError;
    if (ch.encoding !== "protobuf") {
      schemaError = `${ch.topic}: encoding ${JSON.stringify(ch.encoding)}, expected "protobuf"`;
    } else {
      // For protobuf the advertised schema is a base64 FileDescriptorSet (ws-protocol spec).
      const problems = compareDescriptor(ch.schemaName, Buffer.from(ch.schema, "base64"));
      if (problems.length) schemaError = `${ch.topic}: ${problems.join("; ")}`;
    }
    if (schemaError) note(schemaError);
    live.set(ch.id, { topic: ch.topic, schemaName: ch.schemaName, schemaError });
    bySubscription.set(client.subscribe(ch.id), ch.id);
  }
}

function onMessage({ subscriptionId, data }) {
  const ch = live.get(bySubscription.get(subscriptionId));
  if (!ch) return; // late message for a channel the server has since unadvertised
  const result = channels[ch.topic];
  result.messages++;
  if (ch.schemaError) { result.invalid++; return; } // reason already noted once at advertise
  try {
    decodeOfficial(ch.schemaName, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  } catch (e) {
    result.invalid++;
    note(`${ch.topic}: ${e.message}`);
  }
  if (isComplete()) finish();
}

// One connection attempt; resolves true once the server has closed an open connection (then we stop),
// false if the connection never opened (then the caller retries).
function attempt() {
  return new Promise((resolve) => {
    const remaining = deadline - Date.now();
    const ws = new WebSocket(url, SUBPROTOCOLS, {
      handshakeTimeout: Math.max(1, Math.min(2000, remaining)),
    });
    const client = new FoxgloveClient({ ws });
    current = client;
    let opened = false;
    client.on("open", () => {
      opened = true;
      if (!SUBPROTOCOLS.includes(ws.protocol)) {
        note(`server chose subprotocol ${JSON.stringify(ws.protocol)}`);
        finish();
      }
    });
    client.on("advertise", (advertised) => onAdvertise(client, advertised));
    client.on("unadvertise", (ids) => { for (const id of ids) live.delete(id); });
    client.on("message", onMessage);
    // A server's error status (e.g. "Unknown channel ID" for a subscription) explains a channel
    // that never delivers; warnings such as a repeated subscription are not failures.
    client.on("status", (s) => { if (s.level === StatusLevel.ERROR) note(`server: ${s.message}`); });
    client.on("error", (e) => { if (opened) note(`websocket: ${e?.message ?? e}`); });
    client.on("close", () => resolve(opened));
  });
}

// Bounded by the deadline: each attempt ends by its handshake timeout, and finish() exits at the deadline.
while (!finished && Date.now() < deadline) {
  if (await attempt()) {
    note("server closed the connection");
    finish();
  }
  await new Promise((r) => setTimeout(r, RETRY_MS));
}
finish();
