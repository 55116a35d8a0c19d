// Print Foxglove's own ROS 2 definitions of its schemas, as @foxglove/schemas generates
// the foxglove_msgs package from them: `node rosmsg.mjs SceneUpdate ...` -> JSON
// {name: .msg text}. The Python test compares dresslog's schemas/foxglove_msgs with them.
import { foxgloveMessageSchemas, generateRosMsg, generateRosMsgDefinition } from "@foxglove/schemas/internal.js";

const texts = {};
for (const name of process.argv.slice(2)) {
  const schema = foxgloveMessageSchemas[name];
  if (!schema) throw new Error(`no Foxglove schema ${name}`);
  texts[name] = generateRosMsg(generateRosMsgDefinition(schema, { rosVersion: 2 }), { rosVersion: 2 });
}
process.stdout.write(JSON.stringify(texts));
