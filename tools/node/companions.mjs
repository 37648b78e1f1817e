// Reads a Lewis recording as Foxglove does (@mcap/core, @foxglove/rosmsg's ros2msg parser,
// @foxglove/rosmsg2-serialization's CDR reader), decodes every message of every channel,
// and checks the ROS 2 companion channels against the Lewis messages they were made from:
// LaserScan against RangeFinder (ranges, bearings, frame), Odometry against Egomotion,
// /tf_static's sensor frames against the RangeFinders' offsets; and that every channel
// carries the ros2 profile's offered_qos_profiles (a YAML list of profile records).
//
// Usage: node companions.mjs FILE.mcap
// Prints one JSON line {decoded: {topic: count}, checked: {topic: count}, mismatches: [...]}
// and exits 1 on any mismatch, any message that does not decode, or no companion.

import { readFileSync } from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompress } from "fzstd";

const path = process.argv[2];
const reader = new McapStreamReader({
  decompressHandlers: { zstd: (buffer) => decompress(buffer) },
});
reader.append(readFileSync(path));

const schemas = new Map();
const channels = new Map();
const readers = new Map();
const decoded = {};
const checked = {};
const mismatches = [];
const sources = new Map();
const companions = [];
const offsets = new Map();

const f32 = (x) => Math.fround(x);
const yawOf = (q) => Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
const sameAngle = (a, b) => Math.abs(((a - b + 3 * Math.PI) % (2 * Math.PI)) - Math.PI) < 1e-6;
const problem = (where, text) => {
  if (mismatches.length < 50) mismatches.push(`${where}: ${text}`);
};

for (let record; (record = reader.nextRecord()) !== undefined; ) {
  if (record.type === "Schema") {
    schemas.set(record.id, record);
  } else if (record.type === "Channel") {
    channels.set(record.id, record);
    const qos = record.metadata.get("offered_qos_profiles");
    if (qos === undefined || !qos.startsWith("- history: ")) {
      problem(record.topic, `offered_qos_profiles ${JSON.stringify(qos)}`);
    }
    const schema = schemas.get(record.schemaId);
    const text = new TextDecoder().decode(schema.data);
    readers.set(record.id, new MessageReader(parse(text, { ros2: true })));
  } else if (record.type === "Message") {
    const channel = channels.get(record.channelId);
    let message;
    try {
      message = readers.get(record.channelId).readMessage(record.data);
    } catch (e) {
      problem(channel.topic, `message at ${record.logTime} does not decode: ${e}`);
      continue;
    }
    decoded[channel.topic] = (decoded[channel.topic] ?? 0) + 1;
    const schemaName = schemas.get(channel.schemaId).name;
    if (channel.metadata.get("kind") === "ros2-companion") {
      companions.push({ channel, schemaName, logTime: record.logTime, message });
    } else {
      sources.set(`${channel.topic} ${record.logTime}`, { channel, message });
      if (schemaName === "lewis_interfaces/msg/RangeFinder") {
        const provider = channel.metadata.get("provider");
        if (!offsets.has(provider)) offsets.set(provider, new Set());
        offsets.get(provider).add(`${message.x_offset} ${message.y_offset} ${message.z_offset}`);
      }
    }
  }
}

for (const { channel, schemaName, logTime, message } of companions) {
  const where = `${channel.topic} @${logTime}`;
  if (schemaName === "tf2_msgs/msg/TFMessage" && channel.topic === "/tf_static") {
    for (const t of message.transforms) {
      const v = t.transform.translation;
      const known = offsets.get(t.child_frame_id);
      if (known !== undefined && !known.has(`${v.x} ${v.y} ${v.z}`)) {
        problem(where, `${t.child_frame_id} at ${v.x} ${v.y} ${v.z}, its RangeFinder says ${[...known]}`);
      }
    }
    checked[channel.topic] = (checked[channel.topic] ?? 0) + 1;
    continue;
  }
  const source = sources.get(`${channel.metadata.get("source")} ${logTime}`);
  if (source === undefined) {
    problem(where, `no ${channel.metadata.get("source")} message at the same log time`);
    continue;
  }
  const lewis = source.message;
  if (schemaName === "sensor_msgs/msg/LaserScan") {
    if (message.header.frame_id !== source.channel.metadata.get("provider")) {
      problem(where, `frame ${message.header.frame_id}`);
    }
    if (message.ranges.length !== lewis.ranges.length) {
      problem(where, `${message.ranges.length} ranges for ${lewis.ranges.length}`);
    } else {
      for (let i = 0; i < lewis.ranges.length; i++) {
        const got = message.ranges[i];
        const want = f32(lewis.ranges[i]);
        if (got !== want && !(Number.isNaN(got) && Number.isNaN(want))) {
          problem(where, `range ${i}: ${got} != ${want}`);
          break;
        }
      }
    }
    if (message.angle_min !== f32(lewis.theta_offset) || message.angle_increment !== f32(lewis.theta_separation)) {
      problem(where, `bearings ${message.angle_min}+${message.angle_increment} != ${lewis.theta_offset}+${lewis.theta_separation}`);
    }
  } else if (schemaName === "nav_msgs/msg/Odometry") {
    const p = message.pose.pose;
    if (p.position.x !== lewis.pose.x || p.position.y !== lewis.pose.y || !sameAngle(yawOf(p.orientation), lewis.pose.theta)) {
      problem(where, `pose ${JSON.stringify(p)} != ${JSON.stringify(lewis.pose)}`);
    }
    if (message.twist.twist.linear.x !== lewis.translation_velocity) {
      problem(where, "velocity differs");
    }
  } else {
    continue;
  }
  checked[channel.topic] = (checked[channel.topic] ?? 0) + 1;
}

if (companions.length === 0) problem(path, "no companion channel");
console.log(JSON.stringify({ decoded, checked, mismatches }));
process.exit(mismatches.length === 0 ? 0 : 1);
