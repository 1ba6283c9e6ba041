// Rewrites the messages of an MCAP file with @mcap/core's writer (Foxglove's
// TypeScript writer, nobody here wrote it), as a Jazzy-style bag file: profile
// "ros2", ros2msg schemas, cdr channels with their offered_qos_profiles,
// lz4-compressed chunks. Keeps only the topics named. This made the committed
// fixture tests/data/mcap_jazzy/ (see its README).
//
//   NODE_PATH=tools/mcap_check/node_modules node tools/mcap_check/write_fixture.cjs \
//       in.mcap out.mcap /tf /camera/depth/camera_info /camera/depth/image_raw
"use strict";
const fs = require("fs");
const { McapIndexedReader, McapWriter } = require("@mcap/core");
const fzstd = require("fzstd");
const lz4 = require("lz4js");

const decompressHandlers = {
  zstd: (buffer, size) => fzstd.decompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => Uint8Array.from(lz4.decompress(buffer, Number(size))),
};

(async () => {
  const [input, output, ...topics] = process.argv.slice(2);
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
  await writer.start({ profile: "ros2", library: "@mcap/core (tools/mcap_check/write_fixture.cjs)" });
  const schemaIds = new Map(), channelIds = new Map();
  for (const [id, channel] of reader.channelsById) {
    if (!topics.includes(channel.topic)) continue;
    const schema = reader.schemasById.get(channel.schemaId);
    if (!schemaIds.has(schema.id))
      schemaIds.set(schema.id, await writer.registerSchema({ name: schema.name, encoding: schema.encoding, data: schema.data }));
    channelIds.set(id, await writer.registerChannel({
      topic: channel.topic,
      messageEncoding: channel.messageEncoding,
      schemaId: schemaIds.get(schema.id),
      metadata: channel.metadata,
    }));
  }
  let sequence = 0;
  for await (const message of reader.readMessages({ topics })) {
    await writer.addMessage({
      channelId: channelIds.get(message.channelId),
      sequence: sequence++,
      logTime: message.logTime,
      publishTime: message.publishTime,
      data: message.data,
    });
  }
  await writer.end();
  fs.writeFileSync(output, Buffer.concat(chunks.map((c) => Buffer.from(c))));
})().catch((error) => {
  process.stderr.write(`${error.stack}\n`);
  process.exit(1);
});
