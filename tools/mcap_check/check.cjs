// Reads an MCAP file with @mcap/core (Foxglove's TypeScript reader, nobody
// here wrote it) both ways a client does: the indexed reader (footer,
// summary, chunk and message indexes) and the streaming reader (record by
// record), CRCs validated, and prints what it found as one JSON line.
//
//   NODE_PATH=tools/mcap_check/node_modules node tools/mcap_check/check.cjs run_0.mcap
"use strict";
const fs = require("fs");
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");
const fzstd = require("fzstd");
const lz4 = require("lz4js");

const decompressHandlers = {
  zstd: (buffer, size) => fzstd.decompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => Uint8Array.from(lz4.decompress(buffer, Number(size))),
};

async function indexed(path) {
  const handle = await fs.promises.open(path, "r");
  try {
    const readable = {
      size: async () => BigInt((await handle.stat()).size),
      read: async (offset, size) => {
        const buffer = new Uint8Array(Number(size));
        await handle.read(buffer, 0, Number(size), Number(offset));
        return buffer;
      },
    };
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    const counts = {};
    let last = -1n, ordered = true;
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      const topic = reader.channelsById.get(message.channelId).topic;
      counts[topic] = (counts[topic] || 0) + 1;
      if (message.logTime < last) ordered = false;
      last = message.logTime;
    }
    const channels = [...reader.channelsById.values()].map((c) => ({
      topic: c.topic,
      encoding: c.messageEncoding,
      schema: reader.schemasById.get(c.schemaId)?.name ?? "",
      schema_encoding: reader.schemasById.get(c.schemaId)?.encoding ?? "",
      schema_bytes: reader.schemasById.get(c.schemaId)?.data.length ?? 0,
      qos: c.metadata.get("offered_qos_profiles") ?? null,
    }));
    return {
      profile: reader.header.profile,
      chunks: reader.chunkIndexes.length,
      statistics_messages: Number(reader.statistics?.messageCount ?? -1n),
      channels,
      counts,
      ordered,
    };
  } finally {
    await handle.close();
  }
}

function streamed(path) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(fs.readFileSync(path));
  let messages = 0, footer = false, record;
  while ((record = reader.nextRecord()) !== undefined) {
    if (record.type === "Message") ++messages;
    if (record.type === "Footer") footer = true;
  }
  if (!reader.done()) throw new Error("the streaming reader did not reach the end");
  return { messages, footer };
}

(async () => {
  const path = process.argv[2];
  const result = await indexed(path);
  result.streamed = streamed(path);
  process.stdout.write(JSON.stringify(result) + "\n");
})().catch((error) => {
  process.stderr.write(`${process.argv[2]}: ${error.message}\n`);
  process.exit(1);
});
