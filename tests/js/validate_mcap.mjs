// Validate the foxglove.* channels of an MCAP file against the official Foxglove schemas.
// Usage: node tests/js/validate_mcap.mjs FILE.mcap
// Prints {"topics": {topic: {schemaName, messages, invalid}}, "valid": bool, "errors": [...]} and
// exits 0 iff valid and at least one foxglove.* message was seen. Channels whose schema name does
// not start with "foxglove." (the recorder's raw waggle.* channels) are skipped on purpose.

import { open } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";
import { compareDescriptor, decodeOfficial } from "./foxglove_defs.mjs";

const MAX_ERRORS = 10;
const file = process.argv[2];
if (!file || process.argv.length !== 3) {
  process.stderr.write("usage: node validate_mcap.mjs FILE.mcap\n");
  process.exit(2);
}

// Our writers compress chunks with zstd. @foxglove/wasm-zstd is Foxglove's own decoder (zstd built
// to WebAssembly, shipped inside the package, no native build); the pure-JS fzstd was ~18x slower
// (about 50 MB/s), which matters for files full of raw camera frames.
await zstd.isLoaded;
const decompressHandlers = {
  zstd: (buf, size) => zstd.decompress(buf, Number(size)),
};

const topics = {};
const errors = [];
let errorCount = 0;
const fail = (msg) => { errorCount++; if (errors.length < MAX_ERRORS) errors.push(msg); };
const checkedSchemas = new Set();

function onMessage(channel, schema, msg) {
  if (!schema || !schema.name.startsWith("foxglove.")) return;
  const t = (topics[channel.topic] ??= { schemaName: schema.name, messages: 0, invalid: 0 });
  t.messages++;
  if (!checkedSchemas.has(schema.id)) {
    // Once per schema record: the encodings, and that the embedded descriptor says what the official one says.
    checkedSchemas.add(schema.id);
    if (schema.encoding !== "protobuf") fail(`${schema.name}: schema encoding ${JSON.stringify(schema.encoding)}, expected "protobuf"`);
    for (const e of compareDescriptor(schema.name, schema.data)) fail(e);
  }
  if (channel.messageEncoding !== "protobuf") {
    t.invalid++;
    fail(`${channel.topic}: message encoding ${JSON.stringify(channel.messageEncoding)}, expected "protobuf"`);
    return;
  }
  try {
    decodeOfficial(schema.name, msg.data);
  } catch (e) {
    t.invalid++;
    fail(`${channel.topic} seq ${msg.sequence} log_time ${msg.logTime}: ${e.message}`);
  }
}

let fh;
try {
  fh = await open(file, "r");
  const { size } = await fh.stat();
  // Indexed reading needs the summary section; a file cut short (recorder killed) has none, so fall
  // back to reading the data section front to back.
  let indexed;
  try {
    indexed = await McapIndexedReader.Initialize({
      readable: {
        size: async () => BigInt(size),
        read: async (offset, length) => {
          const buf = new Uint8Array(Number(length));
          const { bytesRead } = await fh.read(buf, 0, buf.length, Number(offset));
          if (bytesRead !== buf.length) throw new Error(`short read at ${offset}`);
          return buf;
        },
      },
      decompressHandlers,
    });
  } catch (e) {
    process.stderr.write(`validate_mcap: no usable index (${e.message}); reading as a stream\n`);
  }
  if (indexed) {
    let total = 0;
    for await (const msg of indexed.readMessages()) {
      total++;
      const channel = indexed.channelsById.get(msg.channelId);
      onMessage(channel, indexed.schemasById.get(channel.schemaId), msg);
    }
    // The index could in principle miss messages; the writer's own count must match what we read.
    if (indexed.statistics && indexed.statistics.messageCount !== BigInt(total)) {
      fail(`read ${total} messages but the statistics record says ${indexed.statistics.messageCount}`);
    }
  } else {
    const reader = new McapStreamReader({ decompressHandlers });
    const schemas = new Map();
    const channels = new Map();
    const buf = new Uint8Array(1 << 20);
    for (let pos = 0; pos < size; ) { // bounded by the file size: every read advances pos
      const { bytesRead } = await fh.read(buf, 0, buf.length, pos);
      if (bytesRead === 0) break;
      pos += bytesRead;
      reader.append(buf.slice(0, bytesRead));
      for (let rec; (rec = reader.nextRecord()); ) {
        if (rec.type === "Schema") schemas.set(rec.id, rec);
        else if (rec.type === "Channel") channels.set(rec.id, rec);
        else if (rec.type === "Message") {
          const channel = channels.get(rec.channelId);
          if (!channel) { fail(`message on unknown channel ${rec.channelId}`); continue; }
          onMessage(channel, schemas.get(channel.schemaId), rec);
        }
      }
    }
    if (!reader.done()) fail(`file ends mid-record or without a footer (${reader.bytesRemaining()} bytes unparsed)`);
  }
} catch (e) {
  fail(`reading ${file}: ${e.message}`);
} finally {
  await fh?.close();
}

const total = Object.values(topics).reduce((n, t) => n + t.messages, 0);
if (total === 0) fail("no messages on foxglove.* channels");
if (errorCount > errors.length) errors.push(`... and ${errorCount - errors.length} more`);
const valid = errorCount === 0;
process.stdout.write(JSON.stringify({ topics, valid, errors }) + "\n");
process.exit(valid ? 0 : 1);
