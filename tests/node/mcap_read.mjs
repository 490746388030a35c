// Reads a recording with Foxglove's own decoding stack and prints what it found as JSON.
//
// usage: node mcap_read.mjs FILE
//
// 1. @mcap/core McapStreamReader (validateCrcs) over the whole file: every record, every
//    message decoded with @foxglove/rosmsg2-serialization from the channel's ros2msg schema.
// 2. @mcap/core McapIndexedReader (summary, chunk indexes, validateCrcs): every message again.
// zstd chunks are inflated by @foxglove/wasm-zstd, the decompressor the Foxglove app itself
// uses, so container parsing, CRC checks, decompression and CDR decoding are all Foxglove's.
import { open, readFile } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import * as zstd from "@foxglove/wasm-zstd";

const [file] = process.argv.slice(2);
await zstd.isLoaded;

const decompressHandlers = {
  zstd: (buffer, decompressedSize) => zstd.decompress(buffer, Number(decompressedSize)),
};

function plain(value) {
  if (typeof value === "bigint") return value.toString();
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

function readerFor(schema, readers) {
  let reader = readers.get(schema.id);
  if (!reader) {
    if (schema.encoding !== "ros2msg") throw new Error(`schema ${schema.name}: ${schema.encoding}`);
    const text = new TextDecoder().decode(schema.data);
    reader = new MessageReader(parse(text, { ros2: true }));
    readers.set(schema.id, reader);
  }
  return reader;
}

async function streamRead() {
  const reader = new McapStreamReader({ validateCrcs: true, decompressHandlers });
  reader.append(new Uint8Array(await readFile(file)));
  const schemas = new Map();
  const channels = new Map();
  const readers = new Map();
  const messages = [];
  let header;
  const metadata = {};
  const attachments = [];
  for (let record; (record = reader.nextRecord()); ) {
    switch (record.type) {
      case "Header":
        header = { profile: record.profile, library: record.library };
        break;
      case "Schema":
        schemas.set(record.id, record);
        break;
      case "Channel":
        channels.set(record.id, record);
        break;
      case "Metadata":
        metadata[record.name] = Object.fromEntries(record.metadata);
        break;
      case "Attachment":
        attachments.push({ name: record.name, bytes: record.data.byteLength });
        break;
      case "Message": {
        const channel = channels.get(record.channelId);
        const schema = schemas.get(channel.schemaId);
        const msg = readerFor(schema, readers).readMessage(record.data);
        messages.push({
          topic: channel.topic,
          type: schema.name,
          encoding: channel.messageEncoding,
          log_time: record.logTime.toString(),
          sequence: record.sequence,
          msg: plain(msg),
        });
        break;
      }
      default:
        break;
    }
  }
  if (!reader.done()) throw new Error("stream reader did not reach a valid footer");
  const channelMeta = {};
  for (const channel of channels.values()) {
    channelMeta[channel.topic] = Object.fromEntries(channel.metadata);
  }
  return { header, metadata, attachments, channels: channelMeta, messages };
}

async function indexedRead() {
  const handle = await open(file, "r");
  try {
    const { size } = await handle.stat();
    const readable = {
      size: async () => BigInt(size),
      read: async (offset, length) => {
        const buffer = new Uint8Array(Number(length));
        await handle.read(buffer, 0, Number(length), Number(offset));
        return buffer;
      },
    };
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    const counts = {};
    const readers = new Map();
    let decoded = 0;
    for await (const record of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(record.channelId);
      const schema = reader.schemasById.get(channel.schemaId);
      readerFor(schema, readers).readMessage(record.data);
      decoded += 1;
      counts[channel.topic] = (counts[channel.topic] ?? 0) + 1;
    }
    let attachments = 0;
    for await (const _ of reader.readAttachments({ validateCrcs: true })) attachments += 1;
    return {
      counts,
      decoded,
      attachments,
      chunks: reader.chunkIndexes.length,
      statistics_messages: reader.statistics ? reader.statistics.messageCount.toString() : null,
    };
  } finally {
    await handle.close();
  }
}

const result = { stream: await streamRead(), indexed: await indexedRead() };
process.stdout.write(JSON.stringify(result));
