const fs = require('fs');
const c = require('candied');
const Dbc = c.Dbc;
const text = fs.readFileSync(process.argv[2], 'utf8');
const dbc = new Dbc();
const data = dbc.load(text);
let nsig = 0;
for (const [name, m] of data.messages) {
  const sigs = [...m.signals.values()];
  nsig += sigs.length;
  console.log(`${m.id} ${name} dlc=${m.dlc} attrs=${[...(m.attributes?.keys?.() ?? [])].join(',')}`);
  for (const s of sigs) console.log(`   ${s.name}: ${s.startBit}|${s.length} ${s.endian} ${s.signed ? 'signed' : 'unsigned'} (${s.factor},${s.offset}) [${s.min}|${s.max}] "${s.unit}" vt=${s.valueTable ? s.valueTable.size : 0}`);
}
console.log(`candied parsed ${data.messages.size} messages, ${nsig} signals; errors: ${JSON.stringify(dbc.errors ?? data.errors ?? null)}`);
