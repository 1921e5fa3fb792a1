// The official Foxglove protobuf definitions, and strict checks of messages and embedded schemas
// against them. Shared by live_client.mjs and validate_mcap.mjs.
//
// Where the definitions come from: the npm package @foxglove/schemas (2.1.0) ships no .proto files.
// It ships TypeScript types, JSON schemas (@foxglove/schemas/jsonschema) and, under
// @foxglove/schemas/internal, the schema source of truth (`foxgloveMessageSchemas`,
// `foxgloveEnumSchemas`) together with `generateProto`, the generator Foxglove runs to produce the
// official .proto files that the SDKs (including the Rust `foxglove` crate) compile in. We generate
// the .proto text with that generator and parse it with protobufjs, exactly as the package's own
// test "generates parseable .proto files" does. That gives real protobuf field numbers and wire
// types, which the JSON schemas lack, so a decode is a true check of the bytes on the wire.
// The schema a file or server embeds is never used for decoding; it is only compared to these.

import internal from "@foxglove/schemas/internal.js"; // CommonJS, no "exports" map: needs the .js
import protobuf from "protobufjs";
import descriptor from "protobufjs/ext/descriptor/index.js";

const { foxgloveMessageSchemas, foxgloveEnumSchemas, generateProto } = internal;

// keepCase: field names stay snake_case as in the .proto, so they compare 1:1 with a descriptor.
const root = new protobuf.Root();
root.addJSON(protobuf.common.get("google/protobuf/timestamp.proto").nested);
root.addJSON(protobuf.common.get("google/protobuf/duration.proto").nested);
for (const schema of Object.values(foxgloveMessageSchemas)) {
  // Timestamp/Duration map onto google.protobuf.* (protoEquivalent); there is no foxglove.Timestamp.
  if (schema.protoEquivalent != undefined) continue;
  const enums = Object.values(foxgloveEnumSchemas).filter((e) => e.parentSchemaName === schema.name);
  // Parse into `root` itself (not root.add(parse(..).root), which nests a nameless namespace and
  // yields full names like "..foxglove.Pose"); the imports are the google types added above.
  protobuf.parse(generateProto(schema, enums), root, { keepCase: true });
}
root.resolveAll();

/** The official message type for a schema name like "foxglove.RawImage", or undefined. */
export function officialType(schemaName) {
  if (typeof schemaName !== "string" || !schemaName.startsWith("foxglove.")) return undefined;
  const t = root.lookup(schemaName);
  return t instanceof protobuf.Type ? t : undefined;
}

const utf8 = new TextDecoder("utf-8", { fatal: true });

// protobufjs's decoder is lenient: it skips unknown field numbers and reads a known field by its
// declared type whatever wire type the tag says, so garbage can "decode". This walk rejects any
// field number the official message lacks, any wire-type mismatch, invalid UTF-8 in strings and
// trailing or truncated bytes, recursing into sub-messages.
function walk(type, reader, end) {
  while (reader.pos < end) {
    const tag = reader.uint32();
    const id = tag >>> 3;
    const wire = tag & 7;
    const field = type.fieldsById[id];
    if (!field) throw new Error(`${type.fullName}: unknown field number ${id}`);
    const rt = field.resolvedType;
    const expected = rt instanceof protobuf.Type ? 2 : rt instanceof protobuf.Enum ? 0 : protobuf.types.basic[field.type];
    const packed = field.repeated && wire === 2 && expected !== 2; // packed repeated scalars
    if (wire !== expected && !packed) {
      throw new Error(`${type.fullName}.${field.name}: wire type ${wire}, expected ${expected}`);
    }
    if (rt instanceof protobuf.Type) {
      const len = reader.uint32();
      if (reader.pos + len > end) throw new Error(`${type.fullName}.${field.name}: length beyond message`);
      walk(rt, reader, reader.pos + len);
    } else if (field.type === "string") {
      utf8.decode(reader.bytes()); // throws on invalid UTF-8, as prost and protobuf-es would
    } else if (rt instanceof protobuf.Enum) {
      // proto3 enums are open, so protobufjs accepts any number; an official Foxglove message
      // should only carry the values the official enum defines (e.g. Log.Level 0..5).
      const values = [];
      if (packed) {
        const stop = reader.uint32() + reader.pos;
        while (reader.pos < stop) values.push(reader.int32());
      } else {
        values.push(reader.int32());
      }
      for (const v of values) {
        if (!(v in rt.valuesById)) throw new Error(`${type.fullName}.${field.name}: ${v} is not a ${rt.name} value`);
      }
    } else {
      reader.skipType(wire);
    }
  }
  if (reader.pos !== end) throw new Error(`${type.fullName}: message overruns its length`);
}

/**
 * Decode `bytes` as the official `schemaName`. Returns the decoded message; throws with a reason if
 * the schema is not an official Foxglove one or the bytes are not a valid instance of it.
 */
export function decodeOfficial(schemaName, bytes) {
  const type = officialType(schemaName);
  if (!type) throw new Error(`not an official Foxglove schema: ${JSON.stringify(schemaName)}`);
  walk(type, protobuf.Reader.create(bytes), bytes.length);
  const msg = type.decode(bytes);
  // Belt and braces: protobufjs's own type check of the decoded object.
  const problem = type.verify(msg);
  if (problem) throw new Error(`${schemaName}: ${problem}`);
  return msg;
}

// descriptor.proto FieldDescriptorProto.Type numbers for the scalar types Foxglove uses (and a few more).
const SCALAR = { double: 1, float: 2, int64: 3, uint64: 4, int32: 5, fixed64: 6, fixed32: 7, bool: 8,
  string: 9, bytes: 12, uint32: 13, sfixed32: 15, sfixed64: 16, sint32: 17, sint64: 18 };
const TYPE_MESSAGE = 11, TYPE_ENUM = 14, LABEL_REPEATED = 3;

// Index every message and enum an embedded FileDescriptorSet defines, by full name without a leading dot.
function indexDescriptors(fds) {
  const messages = new Map(), enums = new Map();
  for (const file of fds.file) {
    const stack = (file.messageType || []).map((m) => [file.package ? `${file.package}.${m.name}` : m.name, m]);
    for (const e of file.enumType || []) enums.set(file.package ? `${file.package}.${e.name}` : e.name, e);
    while (stack.length) {
      const [name, m] = stack.pop();
      messages.set(name, m);
      for (const n of m.nestedType || []) stack.push([`${name}.${n.name}`, n]);
      for (const e of m.enumType || []) enums.set(`${name}.${e.name}`, e);
    }
  }
  return { messages, enums };
}

const bare = (name) => (name || "").replace(/^\./, "");

/**
 * Compare an embedded FileDescriptorSet (the bytes a writer put in its MCAP Schema record or
 * WebSocket advertisement) with the official definition: for the top-level message and, recursively,
 * every message and enum it uses, the same field names, numbers, scalar/enum/message types (with
 * type names) and repeatedness, and the same enum values. Returns error strings (empty = same).
 */
export function compareDescriptor(schemaName, fdsBytes) {
  const top = officialType(schemaName);
  if (!top) return [`not an official Foxglove schema: ${JSON.stringify(schemaName)}`];
  let index;
  try {
    index = indexDescriptors(descriptor.FileDescriptorSet.decode(fdsBytes));
  } catch (e) {
    return [`${schemaName}: embedded schema is not a FileDescriptorSet: ${e.message}`];
  }
  const errors = [];
  const seen = new Set();
  const queue = [top];
  while (queue.length) { // bounded: each official type is visited once
    const type = queue.pop();
    const name = bare(type.fullName);
    if (seen.has(name)) continue;
    seen.add(name);
    if (type instanceof protobuf.Enum) {
      const e = index.enums.get(name);
      if (!e) { errors.push(`${schemaName}: embedded schema lacks enum ${name}`); continue; }
      const got = JSON.stringify((e.value || []).map((v) => [v.name, v.number]).sort());
      const want = JSON.stringify(Object.entries(type.values).sort());
      if (got !== want) errors.push(`${name}: embedded enum values ${got}, official ${want}`);
      continue;
    }
    const msg = index.messages.get(name);
    if (!msg) { errors.push(`${schemaName}: embedded schema lacks message ${name}`); continue; }
    const embedded = new Map((msg.field || []).map((f) => [f.number, f]));
    for (const field of type.fieldsArray) {
      const f = embedded.get(field.id);
      embedded.delete(field.id);
      const where = `${name} field ${field.id} (${field.name})`;
      if (!f) { errors.push(`${where}: missing from embedded schema`); continue; }
      const rt = field.resolvedType;
      const want = rt instanceof protobuf.Type ? TYPE_MESSAGE : rt instanceof protobuf.Enum ? TYPE_ENUM : SCALAR[field.type];
      if (f.name !== field.name) errors.push(`${where}: embedded name ${f.name}`);
      if (f.type !== want) errors.push(`${where}: embedded type ${f.type}, official ${want}`);
      if (rt && bare(f.typeName) !== bare(rt.fullName)) errors.push(`${where}: embedded type name ${f.typeName}, official ${bare(rt.fullName)}`);
      if ((f.label === LABEL_REPEATED) !== field.repeated) errors.push(`${where}: repeatedness differs`);
      if (rt) queue.push(rt);
    }
    for (const f of embedded.values()) errors.push(`${name} field ${f.number} (${f.name}): not in the official schema`);
  }
  return errors;
}
