// Decode every message of an MCAP file with Foxglove's own decoders, as its app does:
// @mcap/core reads the records (zstd chunks through @foxglove/wasm-zstd, CRCs checked),
// @foxglove/rosmsg parses each channel's ros2msg schema, and
// @foxglove/rosmsg2-serialization's MessageReader decodes the CDR payloads.
//
//   node decode.mjs TRIAL.mcap  ->  JSON on stdout: per topic, the schema, the number of
//   messages decoded and a digest of the last one (what the Python test checks).
// Any failure (a record, a schema, a payload, trailing bytes) exits 1 with the reason.
import { readFileSync } from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";

await zstd.isLoaded;
const reader = new McapStreamReader({
  validateCrcs: true,
  decompressHandlers: { zstd: (data, size) => zstd.decompress(data, Number(size)) },
});
reader.append(readFileSync(process.argv[2]));

const schemas = new Map();
const channels = new Map();
const topics = {};
for (let record; (record = reader.nextRecord()); ) {
  if (record.type === "Schema") {
    schemas.set(record.id, record);
  } else if (record.type === "Channel") {
    const schema = schemas.get(record.schemaId);
    const text = new TextDecoder().decode(schema.data);
    const decoder = new MessageReader(parse(text, { ros2: true }));
    channels.set(record.id, { topic: record.topic, decoder });
    topics[record.topic] ??= { schema: schema.name, count: 0, last: null };
  } else if (record.type === "Message") {
    const { topic, decoder } = channels.get(record.channelId);
    const message = decoder.readMessage(record.data);
    if (decoder.lastReadHadTrailingBytes()) {
      throw new Error(`${topic}: message at ${record.logTime} has bytes its schema does not use`);
    }
    topics[topic].count += 1;
    topics[topic].last = digest(message);
  }
}
if (!reader.done()) throw new Error("the file ends before its footer");
process.stdout.write(JSON.stringify(topics));

/** The parts of a message the test compares with what dresslog wrote. */
function digest(message) {
  if (message.fields && message.data) {
    // a PointCloud2: its field names and its points' values (all float32 or all float64)
    const Floats = message.fields[0].datatype === 8 ? Float64Array : Float32Array;
    const floats = new Floats(
      message.data.buffer.slice(message.data.byteOffset, message.data.byteOffset + message.data.byteLength),
    );
    return { fields: message.fields.map((f) => f.name), width: message.width, points: Array.from(floats) };
  }
  if (message.markers) {
    return message.markers.map((m) => ({ type: m.type, frame: m.header.frame_id, points: m.points.length }));
  }
  if (message.entities) {
    // a SceneUpdate: each entity's id, frame and triangle lists' sizes
    return message.entities.map((e) => ({
      id: e.id,
      frame: e.frame_id,
      triangles: e.triangles.map((t) => ({ points: t.points.length, indices: t.indices.length })),
    }));
  }
  if (message.transforms) {
    return message.transforms.map((t) => [t.header.frame_id, t.child_frame_id, t.transform.translation]);
  }
  return message.header ? { frame: message.header.frame_id } : {};
}
