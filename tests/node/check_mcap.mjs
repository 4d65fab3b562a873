// Opens a run's run.mcap with the official MCAP reader (@mcap/core, from the npm registry) and
// checks it against the run's own CSV logs: one pose, reference, module-state, wear and solver
// message per step of each controller, in order, with the CSV's poses. Shares no code with the
// writer. Usage: node check_mcap.mjs <run folder> <controller>...
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { McapStreamReader } from "@mcap/core";

const [folder, ...controllers] = process.argv.slice(2);
if (!folder || controllers.length === 0) {
  console.error("usage: node check_mcap.mjs <run folder> <controller>...");
  process.exit(2);
}
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

const reader = new McapStreamReader({ validateCrcs: true });
reader.append(readFileSync(join(folder, "run.mcap")));
const schemas = new Map(), channels = new Map(), messages = new Map();
let header = null, footer = null, record;
while ((record = reader.nextRecord()) !== undefined) {
  if (record.type === "Header") header = record;
  if (record.type === "Footer") footer = record;
  if (record.type === "Schema") {
    check(record.encoding === "jsonschema", `schema ${record.name}: encoding ${record.encoding}`);
    JSON.parse(new TextDecoder().decode(record.data));  // throws if not JSON
    schemas.set(record.id, record);
  }
  if (record.type === "Channel") {
    check(schemas.has(record.schemaId), `channel ${record.topic}: unknown schema ${record.schemaId}`);
    check(record.messageEncoding === "json", `channel ${record.topic}: encoding ${record.messageEncoding}`);
    channels.set(record.id, record);
    messages.set(record.topic, []);
  }
  if (record.type === "Message") {
    const channel = channels.get(record.channelId);
    check(channel !== undefined, `message on unknown channel ${record.channelId}`);
    messages.get(channel.topic).push({ ...record, json: JSON.parse(new TextDecoder().decode(record.data)) });
  }
}
check(reader.done(), "the reader did not reach the end of the file");
check(header !== null && header.library.startsWith("SwerveMPC"), "no header naming SwerveMPC");
check(footer !== null, "no footer");

for (const controller of controllers) {
  const lines = readFileSync(join(folder, `${controller}.csv`), "utf8").trim().split("\n");
  const columns = lines[0].split(",");
  const rows = lines.slice(1).map((line) => line.split(",").map(Number));
  const at = (row, name) => row[columns.indexOf(name)];
  for (const topic of ["pose", "reference", "module_states", "wear", "solver"]) {
    const list = messages.get(`/${controller}/${topic}`);
    check(list !== undefined, `no channel /${controller}/${topic}`);
    if (list === undefined) continue;
    check(list.length === rows.length, `/${controller}/${topic}: ${list.length} messages for ${rows.length} steps`);
    list.forEach((m, k) => {
      check(m.sequence === k, `/${controller}/${topic}: message ${k} has sequence ${m.sequence}`);
      const t = BigInt(Math.round(at(rows[k], "t") * 1e9));
      check(m.logTime === t, `/${controller}/${topic}: message ${k} at ${m.logTime} ns, the CSV's step at ${t}`);
    });
  }
  const poses = messages.get(`/${controller}/pose`) ?? [];
  poses.forEach((m, k) => {
    const p = m.json.pose.position;
    const dx = p.x - at(rows[k], "x"), dy = p.y - at(rows[k], "y");
    check(Math.hypot(dx, dy) < 1e-6, `/${controller}/pose ${k}: (${p.x}, ${p.y}) against the CSV's (${at(rows[k], "x")}, ${at(rows[k], "y")})`);
  });
  const modules = messages.get(`/${controller}/module_states`) ?? [];
  const count = columns.filter((c) => c.startsWith("delta_")).length;
  modules.forEach((m, k) => {
    check(m.json.measured.length === count && m.json.commanded.length === count,
          `/${controller}/module_states ${k}: ${m.json.measured.length} measured, ${m.json.commanded.length} commanded for ${count} modules`);
    m.json.measured.forEach((s, i) => check(Math.abs(s.angle - at(rows[k], `delta_${i}`)) < 1e-6,
                                             `/${controller}/module_states ${k}: module ${i} angle ${s.angle}`));
  });
  const wear = messages.get(`/${controller}/wear`) ?? [];
  wear.forEach((m, k) => {
    for (let i = 0; i < count; ++i) {
      const csv = at(rows[k], `wear_${i}`);
      check(Math.abs(m.json.per_module[i] - csv) <= 1e-6 * Math.max(1, Math.abs(csv)), `/${controller}/wear ${k}: module ${i}`);
    }
  });
}
const total = [...messages.values()].reduce((n, list) => n + list.length, 0);
if (failures.length > 0) {
  console.error(failures.slice(0, 20).join("\n"));
  console.error(`${failures.length} check(s) failed`);
  process.exit(1);
}
console.log(`run.mcap: ${schemas.size} schemas, ${channels.size} channels, ${total} messages, all accounted for`);
