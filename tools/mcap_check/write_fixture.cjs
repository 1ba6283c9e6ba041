// Makes the committed Jazzy-style MCAP bag tests/data/mcap_jazzy/frames/ with
// code nobody on the C++ side wrote: the container by @mcap/core's writer
// (Foxglove's TypeScript library; profile "ros2", ros2msg schemas, cdr
// channels with their offered_qos_profiles, lz4 chunks, summary), and the
// sensor_msgs/msg/PointCloud2 messages encoded as CDR here in JavaScript
// from the depth images and camera info of a bag `workbench dataset export
// --storage mcap` wrote (every 8th pixel in each direction: an organised
// 80 x 60 cloud in the camera's optical frame, NaN where there is no depth).
// /tf_static and /tf are copied as they are. Writes <out>/frames_0.mcap and
// <out>/metadata.yaml.
//
//   NODE_PATH=tools/mcap_check/node_modules node tools/mcap_check/write_fixture.cjs \
//       exported_0.mcap tests/data/mcap_jazzy/frames
"use strict";
const fs = require("fs");
const path = require("path");
const { McapIndexedReader, McapWriter } = require("@mcap/core");
const fzstd = require("fzstd");
const lz4 = require("lz4js");

const STRIDE = 8;

const decompressHandlers = {
  zstd: (buffer, size) => fzstd.decompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => Uint8Array.from(lz4.decompress(buffer, Number(size))),
};

// A reader of CDR (little endian, alignment from the end of the 4-byte
// encapsulation header).
class Cdr {
  constructor(bytes) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.bytes = bytes;
    this.at = 4;
  }
  align(n) { this.at = 4 + Math.ceil((this.at - 4) / n) * n; }
  u8() { return this.view.getUint8(this.at++); }
  u32() { this.align(4); const v = this.view.getUint32(this.at, true); this.at += 4; return v; }
  i32() { this.align(4); const v = this.view.getInt32(this.at, true); this.at += 4; return v; }
  f64() { this.align(8); const v = this.view.getFloat64(this.at, true); this.at += 8; return v; }
  string() { const n = this.u32(); const s = Buffer.from(this.bytes.subarray(this.at, this.at + n - 1)).toString(); this.at += n; return s; }
  header() { return { sec: this.i32(), nanosec: this.u32(), frame_id: this.string() }; }
}

// A writer of CDR, the same rules.
class CdrOut {
  constructor() { this.parts = [Uint8Array.from([0, 1, 0, 0])]; this.size = 0; }
  pad(n) { const p = (n - (this.size % n)) % n; if (p) this.raw(new Uint8Array(p)); }
  raw(bytes) { this.parts.push(bytes); this.size += bytes.length; }
  u8(v) { this.raw(Uint8Array.from([v])); }
  u32(v) { this.pad(4); const b = new Uint8Array(4); new DataView(b.buffer).setUint32(0, v, true); this.raw(b); }
  i32(v) { this.pad(4); const b = new Uint8Array(4); new DataView(b.buffer).setInt32(0, v, true); this.raw(b); }
  string(s) { const b = Buffer.from(s + "\0"); this.u32(b.length); this.raw(b); }
  done() { return Buffer.concat(this.parts.map((p) => Buffer.from(p))); }
}

function cameraInfo(bytes) {
  const r = new Cdr(bytes);
  r.header();
  const height = r.u32(), width = r.u32();
  r.string();
  const d = r.u32();
  for (let i = 0; i < d; ++i) r.f64();
  const k = [];
  for (let i = 0; i < 9; ++i) k.push(r.f64());
  return { width, height, fx: k[0], cx: k[2], fy: k[4], cy: k[5] };
}

function cloudOfImage(bytes, camera) {
  const r = new Cdr(bytes);
  const header = r.header();
  const height = r.u32(), width = r.u32();
  const encoding = r.string();
  r.u8();
  const step = r.u32();
  const n = r.u32();
  const data = r.bytes.subarray(r.at, r.at + n);
  if (encoding !== "16UC1" || width !== camera.width || height !== camera.height)
    throw new Error(`unexpected image ${encoding} ${width}x${height}`);
  const cols = Math.floor(width / STRIDE), rows = Math.floor(height / STRIDE);
  const points = new Float32Array(cols * rows * 3);
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  for (let j = 0; j < rows; ++j) {
    for (let i = 0; i < cols; ++i) {
      const u = i * STRIDE + STRIDE / 2, v = j * STRIDE + STRIDE / 2;
      const mm = view.getUint16(v * step + 2 * u, true);
      const at = 3 * (j * cols + i);
      if (mm === 0) { points[at] = points[at + 1] = points[at + 2] = NaN; continue; }
      const z = mm / 1000;
      points[at] = ((u - camera.cx) * z) / camera.fx;
      points[at + 1] = ((v - camera.cy) * z) / camera.fy;
      points[at + 2] = z;
    }
  }
  const w = new CdrOut();
  w.i32(header.sec); w.u32(header.nanosec); w.string(header.frame_id);
  w.u32(rows); w.u32(cols);
  w.u32(3);
  ["x", "y", "z"].forEach((name, k) => { w.string(name); w.u32(4 * k); w.u8(7); w.u32(1); });
  w.u8(0);
  w.u32(12); w.u32(12 * cols);
  w.u32(points.byteLength); w.raw(new Uint8Array(points.buffer));
  w.u8(0);
  return w.done();
}

const POINTCLOUD2 =
  "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n" +
  "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n" +
  "================================================================================\n" +
  "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" +
  "================================================================================\n" +
  "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n" +
  "================================================================================\n" +
  "MSG: sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\n" +
  "uint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\n" +
  "uint8 datatype\nuint32 count\n";

(async () => {
  const [input, outDir] = process.argv.slice(2);
  const bytes = fs.readFileSync(input);
  const readable = {
    size: async () => BigInt(bytes.length),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const chunks = [];
  const writable = {
    position: () => BigInt(chunks.reduce((n, c) => n + c.length, 0)),
    write: async (buffer) => { chunks.push(Uint8Array.from(buffer)); },
  };
  const writer = new McapWriter({
    writable,
    chunkSize: 786432,
    compressChunk: (data) => ({ compression: "lz4", compressedData: Uint8Array.from(lz4.compress(data)) }),
  });
  await writer.start({ profile: "ros2", library: "@mcap/core 2.2.2 (tools/mcap_check/write_fixture.cjs)" });
  const byTopic = new Map([...reader.channelsById.values()].map((c) => [c.topic, c]));
  const channels = new Map();
  for (const topic of ["/tf_static", "/tf"]) {
    const channel = byTopic.get(topic);
    const schema = reader.schemasById.get(channel.schemaId);
    const schemaId = channels.has("tf") ? channels.get("tf").schemaId
      : await writer.registerSchema({ name: schema.name, encoding: schema.encoding, data: schema.data });
    channels.set("tf", { schemaId });
    channels.set(topic, { id: await writer.registerChannel({ topic, messageEncoding: "cdr", schemaId, metadata: channel.metadata }) });
  }
  const cloudSchema = await writer.registerSchema({
    name: "sensor_msgs/msg/PointCloud2", encoding: "ros2msg", data: Buffer.from(POINTCLOUD2),
  });
  const imageChannel = byTopic.get("/camera/depth/image_raw");
  channels.set("/camera/depth/points", {
    id: await writer.registerChannel({
      topic: "/camera/depth/points", messageEncoding: "cdr", schemaId: cloudSchema, metadata: imageChannel.metadata,
    }),
  });
  let camera = null, sequence = 0, count = 0, first = null, last = null;
  const counts = {};
  for await (const message of reader.readMessages()) {
    const topic = reader.channelsById.get(message.channelId).topic;
    let out = null, data = message.data;
    if (topic === "/camera/depth/camera_info") camera = cameraInfo(message.data);
    if (topic === "/tf_static" || topic === "/tf") out = topic;
    if (topic === "/camera/depth/image_raw") { out = "/camera/depth/points"; data = cloudOfImage(message.data, camera); }
    if (out === null) continue;
    await writer.addMessage({ channelId: channels.get(out).id, sequence: sequence++, logTime: message.logTime, publishTime: message.publishTime, data });
    counts[out] = (counts[out] || 0) + 1;
    ++count;
    first = first === null ? message.logTime : first;
    last = message.logTime;
  }
  await writer.end();
  fs.mkdirSync(outDir, { recursive: true });
  fs.writeFileSync(path.join(outDir, "frames_0.mcap"), Buffer.concat(chunks.map((c) => Buffer.from(c))));
  const qos = (topic) => (byTopic.get(topic === "/camera/depth/points" ? "/camera/depth/image_raw" : topic)
    .metadata.get("offered_qos_profiles") || "").replace(/\n/g, "\\n");
  const types = { "/tf_static": "tf2_msgs/msg/TFMessage", "/tf": "tf2_msgs/msg/TFMessage", "/camera/depth/points": "sensor_msgs/msg/PointCloud2" };
  const topics = Object.keys(counts).map((t) =>
    `    - topic_metadata:\n        name: ${t}\n        type: ${types[t]}\n        serialization_format: cdr\n` +
    `        offered_qos_profiles: "${qos(t)}"\n        type_description_hash: ""\n      message_count: ${counts[t]}\n`).join("");
  fs.writeFileSync(path.join(outDir, "metadata.yaml"),
    "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n" +
    `  duration:\n    nanoseconds: ${last - first}\n  starting_time:\n    nanoseconds_since_epoch: ${first}\n` +
    `  message_count: ${count}\n  topics_with_message_count:\n${topics}` +
    "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - frames_0.mcap\n" +
    `  files:\n    - path: frames_0.mcap\n      starting_time:\n        nanoseconds_since_epoch: ${first}\n` +
    `      duration:\n        nanoseconds: ${last - first}\n      message_count: ${count}\n` +
    "  custom_data: ~\n  ros_distro: jazzy\n");
})().catch((error) => {
  process.stderr.write(`${error.stack}\n`);
  process.exit(1);
});
