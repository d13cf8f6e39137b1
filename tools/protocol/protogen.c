/* swell-protogen: writes the protocol reference (Markdown), the CAN database (.dbc), test vectors
 * for the independent DBC decoder and seed inputs for the fuzzers, all from swell/proto_table.h, and
 * the parameter and scene-key reference from swell/param_table.h and the scene keys (swell/scene.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "swell/cli.h"
#include "swell/param.h"
#include "swell/param_text.h"
#include "swell/pool.h"
#include "swell/proto.h"
#include "swell/scene.h"
#include "swell/transport.h"

static const char usage[] = "usage: swell-protogen [--md FILE] [--params FILE] [--dbc FILE] [--python FILE]\n"
			    "                      [--vectors FILE [--count N] [--seed S]] [--corpus DIR]\n"
			    "Writes, from the one message table (swell/proto_table.h) and parameter table\n"
			    "(swell/param_table.h, with the scene file's start-up keys):\n"
			    "  --md FILE       the protocol reference: carriers, one annotated frame per message,\n"
			    "                  the bus-load budget (docs/protocol.md)\n"
			    "  --params FILE   the parameter and scene-key reference (docs/parameters.md)\n"
			    "  --dbc FILE      the CAN database for node 0 (docs/swell.dbc)\n"
			    "  --python FILE   the tables of the Python package (host/python/swell/_tables.py)\n"
			    "  --vectors FILE  classic CAN frames from the C encoder, one line each, with the\n"
			    "                  physical values they encode (input of tools/protocol/dbc_check.py)\n"
			    "  --count N       frames per message type in --vectors (default 200)\n"
			    "  --seed S        random seed for --vectors (default 1)\n"
			    "  --corpus DIR    seed inputs for the fuzzers in DIR/can, DIR/canfd, DIR/pkt\n"
			    "Exit status: 0 written, 1 a file could not be written, 2 bad arguments.\n";

/* ---- helpers ---- */
static void phys(char *buf, size_t n, int64_t raw, const struct swell_field_desc *f)
{
	snprintf(buf, n, "%.15g", (double)raw * strtod(f->factor, NULL));
}

static uint64_t rng_state = 1;
static uint64_t rnd(void)
{
	/* xorshift64*: deterministic across hosts */
	rng_state ^= rng_state >> 12;
	rng_state ^= rng_state << 25;
	rng_state ^= rng_state >> 27;
	return rng_state * 2685821657736338717ull;
}

static int64_t rnd_range(int64_t lo, int64_t hi)
{
	uint64_t span = (uint64_t)(hi - lo) + 1u;

	return span == 0 ? (int64_t)rnd() : lo + (int64_t)(rnd() % span);
}

static void random_msg(const struct swell_msg_desc *d, struct swell_msg *m, int which)
{
	unsigned i;

	memset(m, 0, sizeof(*m));
	m->type = d->type;
	for (i = 0; i < d->nfields; i++) {
		const struct swell_field_desc *f = &d->fields[i];
		int64_t v = which == 0 ? f->min : which == 1 ? f->max : rnd_range(f->min, f->max);

		swell_msg_field_set(m, f, v);
	}
}

/* ---- bus load ---- */
/* CAN FD, 11-bit id, bit-rate switch: nominal bits (arbitration 17 + 4 stuff, CRC delimiter, ACK,
 * EOF, IFS: 13) and data-phase bits (ESI, DLC, data, worst-case dynamic stuffing, stuff count,
 * CRC-17/21 with its fixed stuff bits). Returns microseconds. */
static double canfd_us(unsigned n, double nominal, double data)
{
	unsigned crc = n <= 16 ? 17u : 21u;
	unsigned dyn = 5u + 8u * n;
	unsigned dbits = dyn + dyn / 4u + 4u + crc + (4u + crc + 3u) / 4u;
	unsigned nbits = 17u + 4u + 13u;

	return 1e6 * (nbits / nominal + dbits / data);
}

static unsigned msg_len(unsigned type)
{
	return swell_msg_desc_find(type)->len;
}

struct load_row {
	const char *carrier;
	unsigned rate;
	int minimal; /* 1: FORCE_CMD + DEVICE_POS only; 2: effect mode (an effect set and a sample an update) */
};

/* Telemetry that is not per tick: heartbeat 10 Hz both ways, ENERGY 10 Hz, scene and controller info 1 Hz each,
 * object pose and force at 100 Hz (viewer rate). */
#define HB_HZ 20.0
#define ENERGY_HZ 10.0 /* the energy account, with the controller's heartbeat */
#define SCENE_HZ 1.0
#define INFO_HZ 1.0
#define OBJ_HZ 100.0
/* the reference scene in quads of 2 x 2 cells */
static const unsigned grid_quads = SWELL_POOL_N / 2 * (SWELL_POOL_N / 2);
#define UPDATE_HZ ((double)SWELL_POOL_SOLVER_HZ) /* effect mode: the update rate, the reference solver's */
#define USB_PACKETS_PER_MS 19.0 /* USB 2.0 full speed: at most 19 bulk packets of 64 bytes per frame */

static void bus_load(FILE *o)
{
	static const struct load_row rows[] = {
		{ "classic CAN 1 Mbit/s", 1000, 0 },
		{ "classic CAN 1 Mbit/s", 1000, 1 },
		{ "classic CAN 1 Mbit/s", SWELL_POOL_TICK_HZ, 0 },
		{ "classic CAN 1 Mbit/s", SWELL_POOL_TICK_HZ, 1 },
		{ "classic CAN 1 Mbit/s", 1000, 2 },
		{ "classic CAN 1 Mbit/s", SWELL_POOL_TICK_HZ, 2 },
		{ "CAN FD 1/2 Mbit/s", 1000, 0 },
		{ "CAN FD 1/2 Mbit/s", SWELL_POOL_TICK_HZ, 0 },
		{ "USB full speed", 1000, 0 },
		{ "USB full speed", SWELL_POOL_TICK_HZ, 0 },
	};
	unsigned i;

	fprintf(o,
		"## Bus-load budget\n\n"
		"Computed by swell-protogen from the message lengths. Per haptic tick the device link\n"
		"carries FORCE_CMD down and DEVICE_POS, DEVICE_VEL, DEVICE_FORCE up (\"full\"), or only\n"
		"FORCE_CMD and DEVICE_POS (\"minimal\": the controller differentiates position and has no\n"
		"measured force). In effect mode (`force.mode` = 1, \"effect\") the device link carries, per\n"
		"update (%.0f Hz, the solver's rate, whatever the haptic rate), EFFECT_SPRING, EFFECT_DAMPER\n"
		"and EFFECT_LIMIT down and DEVICE_POS and DEVICE_VEL up (the device reports once an update;\n"
		"no FORCE_CMD while RUNNING). Telemetry on the same bus: HEARTBEAT %.0f/s (both directions),\n"
		"ENERGY %.0f/s, SCENE %.0f/s, CTL_INFO %.0f/s, OBJECT_POSE and OBJECT_FORCE %.0f/s each. What is left\n"
		"carries HEIGHT_QUADs; a full refresh of the 64 x 64 reference grid is %u quads.\n\n",
		UPDATE_HZ, HB_HZ, ENERGY_HZ, SCENE_HZ, INFO_HZ, OBJ_HZ, grid_quads);
	fprintf(o,
		"- Classic CAN: %u bits per 8-byte frame and %u per 7-byte frame, worst-case bit\n"
		"  stuffing (47 + 8n + floor((33 + 8n) / 4)).\n",
		swell_can_bits(8), swell_can_bits(7));
	fprintf(o,
		"- CAN FD: 1 Mbit/s arbitration, 2 Mbit/s data, worst-case stuffing: %.1f us per\n"
		"  8-byte frame, %.1f us per 64-byte frame (8 quads). Per-tick messages are of different\n"
		"  types, so they go one per frame; quads go 8 per frame.\n",
		canfd_us(8, 1e6, 2e6), canfd_us(64, 1e6, 2e6));
	fprintf(o,
		"- USB full speed bulk: budgeted at %.0f packets of 64 bytes per 1 ms frame (the USB 2.0\n"
		"  maximum; real host controllers may schedule fewer). Per tick one packet down (FORCE_CMD)\n"
		"  and one up (the three device messages: %u bytes); telemetry %u packets/s; quads go %u\n"
		"  per packet.\n"
		"- UDP on loopback: bounded by the host CPU, not budgeted.\n\n"
		"| carrier | haptic rate | device traffic | control load | left for heights | "
		"64x64 refreshes/s | verdict |\n"
		"|---|---|---|---|---|---|---|\n",
		USB_PACKETS_PER_MS,
		SWELL_PKT_OVERHEAD + 3u + msg_len(SWELL_MSG_DEVICE_POS) + msg_len(SWELL_MSG_DEVICE_VEL) +
			msg_len(SWELL_MSG_DEVICE_FORCE),
		(unsigned)(HB_HZ + ENERGY_HZ + SCENE_HZ + INFO_HZ + OBJ_HZ),
		(SWELL_PKT_MAX - SWELL_PKT_OVERHEAD) / (1u + msg_len(SWELL_MSG_HEIGHT_QUAD)));
	for (i = 0; i < sizeof(rows) / sizeof(rows[0]); i++) {
		const struct load_row *r = &rows[i];
		double busy_s, quads_s, quad_s_each;
		const char *verdict;

		if (r->carrier[0] == 'c' && r->minimal == 2) {
			const double update = swell_can_bits(msg_len(SWELL_MSG_EFFECT_SPRING)) +
				swell_can_bits(msg_len(SWELL_MSG_EFFECT_DAMPER)) +
				swell_can_bits(msg_len(SWELL_MSG_EFFECT_LIMIT)) +
				swell_can_bits(msg_len(SWELL_MSG_DEVICE_POS)) +
				swell_can_bits(msg_len(SWELL_MSG_DEVICE_VEL));

			busy_s = (update * UPDATE_HZ +
				  swell_can_bits(8) * (HB_HZ + ENERGY_HZ + SCENE_HZ + INFO_HZ + 2 * OBJ_HZ)) /
				1e6;
			quad_s_each = swell_can_bits(msg_len(SWELL_MSG_HEIGHT_QUAD)) / 1e6;
		} else if (r->carrier[0] == 'c') {
			double tick = swell_can_bits(msg_len(SWELL_MSG_FORCE_CMD)) +
				swell_can_bits(msg_len(SWELL_MSG_DEVICE_POS));
			if (!r->minimal)
				tick += swell_can_bits(msg_len(SWELL_MSG_DEVICE_VEL)) +
					swell_can_bits(msg_len(SWELL_MSG_DEVICE_FORCE));
			busy_s = (tick * r->rate +
				  swell_can_bits(8) * (HB_HZ + ENERGY_HZ + SCENE_HZ + INFO_HZ + 2 * OBJ_HZ)) /
				1e6;
			quad_s_each = swell_can_bits(msg_len(SWELL_MSG_HEIGHT_QUAD)) / 1e6;
		} else if (r->carrier[0] == 'C') {
			double tick = 2 * canfd_us(8, 1e6, 2e6) + 2 * canfd_us(8, 1e6, 2e6); /* 7 bytes -> 8 */
			busy_s = (tick * r->rate +
				  canfd_us(8, 1e6, 2e6) * (HB_HZ + ENERGY_HZ + SCENE_HZ + INFO_HZ + 2 * OBJ_HZ)) /
				1e6;
			quad_s_each = canfd_us(64, 1e6, 2e6) / 8.0 / 1e6;
		} else {
			double per_s = USB_PACKETS_PER_MS * 1000.0;
			busy_s = (2.0 * r->rate + HB_HZ + ENERGY_HZ + SCENE_HZ + INFO_HZ + OBJ_HZ) / per_s;
			/* whole records per packet */
			const unsigned quads_per_pkt =
				(SWELL_PKT_MAX - SWELL_PKT_OVERHEAD) / (1u + msg_len(SWELL_MSG_HEIGHT_QUAD));

			quad_s_each = 1.0 / per_s / quads_per_pkt;
		}
		quads_s = busy_s < 1.0 ? (1.0 - busy_s) / quad_s_each : 0.0;
		verdict = busy_s > 1.0 ? "does not fit" : busy_s > 0.7 ? "fits, tight (> 70 %)" : "fits";
		fprintf(o, "| %s | %u Hz | %s | %.1f %% | %.0f quads/s | %.1f | %s |\n", r->carrier, r->rate,
			r->minimal == 2      ? "effect"
				: r->minimal ? "minimal"
					     : "full",
			100.0 * busy_s, quads_s, quads_s / grid_quads, verdict);
	}
	fprintf(o,
		"\nConclusions. Classic CAN carries the full device link at 1000 Hz, and at 2500 Hz only\n"
		"the minimal one (70 %%, tight), or full haptic control in effect mode, where the load\n"
		"follows the update rate and not the haptic rate; what is left moves a few changed tiles\n"
		"per tick, never the whole grid at the solver rate (250 Hz x %u quads). CAN FD helps the\n"
		"heights (8 quads a frame) but not the per-tick messages: they are short, one per frame, and\n"
		"the 1 Mbit/s arbitration phase dominates, so the full device link at 2500 Hz is tight on\n"
		"CAN FD too. USB carries everything at both rates with room for about 80 full refreshes per\n"
		"second. Only changed tiles are sent, so a calm pool costs nothing.\n\n",
		grid_quads);
}

/* ---- Markdown ---- */
static const char *type_name(const struct swell_field_desc *f)
{
	static char buf[8];

	snprintf(buf, sizeof(buf), "%c%u", f->min < 0 ? 's' : 'u', f->bits);
	return buf;
}

static void write_md_states(FILE *o)
{
	fprintf(o, "\n## Controller states\n\nHEARTBEAT.state:");
#define SWELL_X(NAME, code, name) fprintf(o, " %d %s%s", code, name, code < SWELL_CTL_FAULT ? "," : ".");
	SWELL_STATES(SWELL_X)
#undef SWELL_X
	fprintf(o,
		"\n\nParameters travel in PARAM_SET / PARAM_GET / PARAM_ACK / PARAM_NACK as an id and a raw\n"
		"int32 value; their ids, units, defaults, ranges and the states that take them are in\n"
		"[parameters.md](parameters.md), generated from the same tables.\n\n");
}

/* One reference row: a parameter of the table or a start-up key of scene files. */
static void param_row(FILE *o, const struct swell_param_desc *d, const char *who)
{
	char def[48], lo[48], hi[48];

	swell_param_format(d, d->def, def, sizeof(def));
	swell_param_format(d, d->min, lo, sizeof(lo));
	swell_param_format(d, d->max, hi, sizeof(hi));
	const int ro = d->access == SWELL_PACCESS_RO;

	fprintf(o, "| `%s` | 0x%04X | %s | %s | %s .. %s | %ld .. %ld x %s | %s | %s | %s |\n", d->name, d->id,
		d->unit[0] ? d->unit : "-", ro ? "-" : def, lo, hi, (long)d->min, (long)d->max, d->factor,
		ro ? "nobody: the controller measures it" : who,
		ro                                ? "read only"
			: d->id >= SWELL_SCENE_NX ? "outside RUNNING (start-up)"
						  : swell_param_when_text(d->when),
		d->desc);
}

static void write_params(FILE *o)
{
	static const uint16_t scene_keys[] = { SWELL_SCENE_NX, SWELL_SCENE_NY, SWELL_SCENE_DX_UM, SWELL_SCENE_DEPTH_UM,
					       SWELL_SCENE_SOLVER_HZ };
	const struct swell_param_desc *t;
	size_t n, k;

	fprintf(o,
		"<!-- Generated by swell-protogen --params from common/include/swell/param_table.h and the\n"
		"     scene keys of common/src/host/scene.c: do not edit. -->\n"
		"# Parameters and scene keys\n\n"
		"Reference. Every value a lab user or a tool can change on a controller, with its unit,\n"
		"default, range and who may change it when. The parameter table\n"
		"(`common/include/swell/param_table.h`) is the one source of the controller's get/set, of\n"
		"swell-tool's names and units and of this page; the scene file's start-up keys come from\n"
		"`common/src/host/scene.c`.\n\n"
		"- **Default** is the reference scene's: %u x %u cells of %.2f mm, depth %.0f mm, solver\n"
		"  %u Hz, a %.0f mm cube of 100 g.\n"
		"- **Range** is checked first: a value outside it is refused (PARAM_NACK `range`) and nothing\n"
		"  changes. Inside it the owning module checks the whole configuration (the solver's\n"
		"  stability, the force law's limits) and may refuse with its own reason.\n"
		"- **Raw** is what travels in PARAM_SET / PARAM_GET: a raw int32, physical = raw x factor.\n"
		"- **When**: `%s`, `%s`, `%s` (a write outside it is refused with\n"
		"  PARAM_NACK `state`); start-up keys are taken outside RUNNING and restart the controller's\n"
		"  core with the water at rest.\n\n"
		"## Parameters\n\n"
		"Written on the host link by `swell-tool set NAME VALUE`, by any viewer or tool speaking\n"
		"PARAM_SET, and by a scene file (`swell-ctl --scene FILE` at start, `swell-tool scene load\n"
		"FILE` on a running controller). The controller never changes one by itself; every answer\n"
		"carries the value now in force.\n\n"
		"| name | id | unit | default | range | raw x factor | changed by | when | meaning |\n"
		"|---|---|---|---|---|---|---|---|---|\n",
		(unsigned)SWELL_POOL_N, (unsigned)SWELL_POOL_N, SWELL_POOL_DX_UM / 1000.0, SWELL_POOL_DEPTH_UM / 1000.0,
		(unsigned)SWELL_POOL_SOLVER_HZ, SWELL_POOL_BOX_UM / 1000.0, swell_param_when_text(SWELL_PWHEN_ANY),
		swell_param_when_text(SWELL_PWHEN_DRY), swell_param_when_text(SWELL_PWHEN_IDLE));
	t = swell_param_table(&n);
	for (k = 0; k < n; k++)
		param_row(o, &t[k], "host link, scene file");
	fprintf(o,
		"\nRead-only parameters are what the controller measures: `swell-tool get NAME` reads them, a\n"
		"set is refused (`invalid argument`), a scene file may not name them.\n"
		"\n## Scene keys (start-up)\n\n"
		"The pool and the solver rate are laid out in memory at start. `swell-ctl --scene FILE` and\n"
		"its options set them at start; on a running controller, PARAM_SETs of the four `pool.*`\n"
		"keys outside RUNNING (`swell-tool scene load FILE`) restart its core with that pool, and a\n"
		"pool that does not fit the controller's memory is refused. `solver.hz` is a scene-file and\n"
		"command-line key only. When a scene gives the pool or the solver rate and not `wave.e`,\n"
		"`wave.e` follows eq. 2 from them.\n\n"
		"| name | id | unit | default | range | raw x factor | changed by | when | meaning |\n"
		"|---|---|---|---|---|---|---|---|---|\n");
	for (k = 0; k < sizeof(scene_keys) / sizeof(scene_keys[0]); k++) {
		const struct swell_param_desc *d = swell_scene_key(scene_keys[k]);

		if (d)
			param_row(o, d,
				  d->id == SWELL_SCENE_SOLVER_HZ ? "scene file, `swell-ctl --solver-hz`"
								 : "scene file, host link (`pool.*`)");
	}
	fprintf(o,
		"\n## Commands\n\nParameter %d (`%s`) is write only: its value is a command, answered by\n"
		"PARAM_ACK with the value echoed, or PARAM_NACK (a GET is refused as invalid). `swell-tool`\n"
		"sends them as `swell-tool run`, `stop`, `clear`.\n\n"
		"| value | command | effect |\n|---|---|---|\n",
		SWELL_PARAM_COMMAND_ID, SWELL_PARAM_COMMAND_NAME);
#define SWELL_X(NAME, value, name, desc) fprintf(o, "| %d | %s | %s |\n", value, name, desc);
	SWELL_COMMANDS(SWELL_X)
#undef SWELL_X
}

/* The example value of field j of n: spread over its range by position (a flag set, a sequence
 * number 42, the protocol version). */
static int64_t example_raw(const struct swell_field_desc *f, unsigned j, unsigned n)
{
	if (f->bits == 1)
		return f->max;
	if (f->kind == SWELL_FK_SEQ)
		return f->max >= 42 ? 42 : f->max;
	if (f->kind == SWELL_FK_VERSION)
		return SWELL_PROTO_VERSION;
	return f->min + (f->max - f->min) * (int64_t)(2u * j + 1u) / (int64_t)(2u * n);
}

/* One classic CAN frame of d, byte by byte: which bits of which field each byte holds. */
static void write_example(FILE *o, const struct swell_msg_desc *d)
{
	struct swell_msg m;
	uint32_t id;
	uint8_t data[8], len;
	unsigned j, b;

	memset(&m, 0, sizeof(m));
	m.type = d->type;
	for (j = 0; j < d->nfields; j++)
		swell_msg_field_set(&m, &d->fields[j], example_raw(&d->fields[j], j, d->nfields));
	if (swell_can_encode(&m, &id, data, &len) != SWELL_OK) {
		fprintf(o, "(no example: the encoder refused it)\n\n");
		return;
	}
	fprintf(o, "Example on classic CAN, node 0: id 0x%03X, %u bytes `", (unsigned)id, len);
	for (b = 0; b < len; b++)
		fprintf(o, "%s%02X", b ? " " : "", data[b]);
	fprintf(o, "`\n\n| byte | hex | bits 7..0 | holds |\n|---|---|---|---|\n");
	for (b = 0; b < len; b++) {
		int any = 0;

		fprintf(o, "| %u | %02X | ", b, data[b]);
		for (j = 8; j-- > 0;)
			fputc(data[b] >> j & 1u ? '1' : '0', o);
		fprintf(o, " | ");
		/* fields from the byte's high bits down, as the bits column reads */
		for (j = d->nfields; j-- > 0;) {
			const struct swell_field_desc *f = &d->fields[j];
			unsigned lo = 8u * b, hi = 8u * b + 7u, s = f->start, e = f->start + f->bits - 1u;

			if (e < lo || s > hi)
				continue;
			lo = s > lo ? s : lo;
			hi = e < hi ? e : hi;
			if (hi == lo)
				fprintf(o, "%s%s[%u] in bit %u", any ? "; " : "", f->name, lo - s, lo - 8u * b);
			else
				fprintf(o, "%s%s[%u:%u] in bits %u..%u", any ? "; " : "", f->name, hi - s, lo - s,
					hi - 8u * b, lo - 8u * b);
			any = 1;
		}
		fprintf(o, "%s |\n", any ? "" : "(padding, 0)");
	}
	fprintf(o, "\nDecoded:");
	for (j = 0; j < d->nfields; j++) {
		const struct swell_field_desc *f = &d->fields[j];
		int64_t raw = swell_msg_field_get(&m, f);
		char v[32];

		phys(v, sizeof(v), raw, f);
		fprintf(o, "%s %s = %lld", j ? ";" : "", f->name, (long long)raw);
		if (strcmp(f->factor, "1") || f->unit[0])
			fprintf(o, " -> %s%s%s", v, f->unit[0] ? " " : "", f->unit);
	}
	fprintf(o, ".\n\n");
}

static void write_md(FILE *o)
{
	unsigned i, j, e;

	fprintf(o,
		"<!-- Generated by swell-protogen from common/include/swell/proto_table.h: do not edit. -->\n"
		"# swell wire protocol, version %d\n\n"
		"Reference. One table (`common/include/swell/proto_table.h`) is the single source of the C codecs\n"
		"(`swell/proto.h`), the CAN database (`docs/swell.dbc`) and this page. Every message has a\n"
		"fixed layout of at most 8 bytes, little-endian (Intel) bit order, integer units; the\n"
		"physical value is raw x factor. Raw values outside the stated range, and set bits that no\n"
		"field covers, make the whole frame invalid.\n\n",
		SWELL_PROTO_VERSION);

	fprintf(o,
		"## Carriers\n\n"
		"- **Classic CAN** (1 Mbit/s): one message per frame, DLC = message length, 11-bit id =\n"
		"  `type << 4 | node` (node 0-%u, so several controllers share a bus; the DBC lists node 0).\n"
		"  Lower id wins arbitration: force command and device state first, telemetry last.\n",
		SWELL_NODE_MAX);
	fprintf(o,
		"- **CAN FD** (64 bytes): the same id; the frame holds k messages of that one type, each in\n"
		"  a slot of its length rounded up to 4 bytes (zero padding), k chosen so that the length is\n"
		"  a CAN FD length (8 slots of 8 bytes or 16 of 4 in a 64-byte frame).\n"
		"- **Packets** (USB bulk, UDP datagrams; the same bytes on both), at most %u bytes:\n\n"
		"  | offset | size | content |\n  |---|---|---|\n"
		"  | 0 | 1 | magic 0x%02X |\n  | 1 | 1 | protocol version (%d) |\n"
		"  | 2 | 1 | node 0-%u |\n  | 3 | 1 | packet sequence number (+1 per packet, wraps) |\n"
		"  | 4 | 1 | record count n >= 1 |\n  | 5 | ... | n records: message type (1 byte), payload |\n"
		"  | end-4 | 4 | CRC-32 (IEEE, as zlib) of every byte before it, little-endian |\n\n",
		SWELL_PKT_MAX, SWELL_PKT_MAGIC, SWELL_PROTO_VERSION, SWELL_NODE_MAX);
	fprintf(o,
		"USB identity: VID 0x%04X, PID 0x%04X (pid.codes test PID), interface %u of class 0x%02X,\n"
		"bulk OUT 0x%02X (host to controller), bulk IN 0x%02X (controller to host), %u-byte packets,\n"
		"one swell packet per USB packet. Hosts take the endpoint addresses from the interface\n"
		"descriptor: a Linux FunctionFS gadget may be given others by its UDC (dummy_hcd: OUT 0x02).\n"
		"UDP (software in the loop): the controller listens on\n"
		"%s:%u for the device link and sends telemetry to the viewer at %s:%u.\n\n"
		"Integrity: CAN frames carry the bus CRC; packets carry CRC-32. Streams carry 8-bit\n"
		"sequence numbers (field kind SEQ below); the heartbeat carries the protocol version.\n\n",
		SWELL_USB_VID, SWELL_USB_PID, SWELL_USB_IFACE, SWELL_USB_CLASS, SWELL_USB_EP_OUT, SWELL_USB_EP_IN,
		SWELL_USB_PACKET, SWELL_UDP_HOST, SWELL_UDP_PORT_DEVICE, SWELL_UDP_HOST, SWELL_UDP_PORT_VIEWER);

	fprintf(o,
		"## Heights\n\n"
		"The solver keeps heights as int32 with LSB 2^-16 mm relative to the rest depth. On the\n"
		"wire a sample is int12 with LSB 2^-%d mm (%.4g um), saturated to [%.4g, %.6g] mm:\n"
		"`sample = clamp((h + 2^%d) >> %d, -2048, 2047)` (round to nearest). The grid is cut into\n"
		"tiles of %d x %d cells (up to 32 x 32 tiles, so grids up to 256 x 256); a changed tile is\n"
		"sent as 16 HEIGHT_QUADs (4 cells of one tile row each). Cells outside the grid are sent as\n"
		"0. SCENE, sent at 1 Hz and on change, gives the grid size, cell size, depth and the height\n"
		"LSB, so a viewer can join at any time. CTL_INFO, sent at the controller's first tick, then\n"
		"at 1 Hz and whenever the object's size changes, gives the firmware version (a flasher finds\n"
		"the controller again after an update by it) and the object's box a x b x H, so a viewer\n"
		"draws what the controller simulates. A new message type: the layouts above it are\n"
		"unchanged and the protocol version stays; a decoder older than it rejects the packets that\n"
		"carry one (unknown type) and counts them.\n\n",
		SWELL_PROTO_H_SHIFT, 1000.0 / (1 << SWELL_PROTO_H_SHIFT), -2048.0 / (1 << SWELL_PROTO_H_SHIFT),
		2047.0 / (1 << SWELL_PROTO_H_SHIFT), 15 - SWELL_PROTO_H_SHIFT, 16 - SWELL_PROTO_H_SHIFT,
		SWELL_PROTO_TILE, SWELL_PROTO_TILE);

	fprintf(o,
		"## Messages\n\n| message | type | CAN id (node 0) | bytes | from | to | purpose |\n"
		"|---|---|---|---|---|---|---|\n");
	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		fprintf(o, "| %s | 0x%02X | 0x%03X | %u | %s | %s | %s |\n", d->name, d->type,
			(unsigned)SWELL_CAN_ID(d->type, 0), d->len, d->from, d->to, d->desc);
	}
	fprintf(o,
		"\nNodes: CTL the controller; DEV the device node: the HapticMaster model (swell-hm), or\n"
		"swell-hmbridge in front of a real HapticMaster, which speaks only its own TCP interface\n"
		"([hapticmaster.md](hapticmaster.md)); VIEW the viewer and tools. CAN id 0x000-0x00F (type 0)\n"
		"is reserved.\n\n"
		"Each message below has its field table and one example frame on classic CAN, decoded byte\n"
		"by byte. Bit i of a message is bit i %% 8 of byte i / 8 (little-endian, Intel order); a\n"
		"field of bits a-b holds its value's bit 0 at bit a; a signed field is two's complement over\n"
		"its bits. `name[h:l] in bits x..y` says that bits h..l of the field's raw value sit in bits\n"
		"x..y of that byte. The example values are spread over each field's range, not typical\n"
		"values.\n\n");

	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		fprintf(o, "### %s (type 0x%02X, %u bytes, %s to %s)\n\n%s\n\n", d->name, d->type, d->len, d->from,
			d->to, d->desc);
		fprintf(o,
			"| field | bits | type | raw range | factor | physical range | unit | kind | meaning |\n"
			"|---|---|---|---|---|---|---|---|---|\n");
		for (j = 0; j < d->nfields; j++) {
			const struct swell_field_desc *f = &d->fields[j];
			char lo[32], hi[32];

			phys(lo, sizeof(lo), f->min, f);
			phys(hi, sizeof(hi), f->max, f);
			fprintf(o, "| %s | %u-%u | %s | %lld .. %lld | %s | %s .. %s | %s | %s | %s |\n", f->name,
				f->start, f->start + f->bits - 1u, type_name(f), (long long)f->min, (long long)f->max,
				f->factor, lo, hi, f->unit[0] ? f->unit : "-",
				f->kind == SWELL_FK_SEQ               ? "SEQ"
					: f->kind == SWELL_FK_VERSION ? "VERSION"
								      : "",
				f->desc);
		}
		fprintf(o, "\n");
		write_example(o, d);
	}

	fprintf(o,
		"## Error codes (enum swell_err)\n\nUsed in HEARTBEAT.err, PARAM_NACK.err and as the\n"
		"reason a decoder rejects a frame (counted per reason in `struct swell_proto_stats`):\n\n"
		"| value | meaning | decoder rejects a frame for |\n|---|---|---|\n");
	for (e = 0; e < SWELL_ERR_COUNT; e++) {
		static const char *why[SWELL_ERR_COUNT] = {
			[SWELL_EUNKNOWN] = "unknown type, 29-bit id, wrong packet magic, unknown record type",
			[SWELL_ETRUNC] = "shorter than the message, partial CAN FD slot, record past the end",
			/* NOLINTNEXTLINE(bugprone-suspicious-missing-comma): one text on two lines */
			[SWELL_ESIZE] = "longer than the message, no CAN FD length, > 64 bytes, bytes after the "
					"last record, record count 0 or above the caller's room",
			[SWELL_EVERSION] = "packet or heartbeat of another protocol version",
			[SWELL_ECRC] = "packet CRC-32 mismatch",
			[SWELL_ERANGE] = "field outside its range, reserved or padding bits set, node > 15",
		};
		fprintf(o, "| %u | %s | %s |\n", e, swell_err_str((enum swell_err)e), why[e] ? why[e] : "");
	}
	write_md_states(o);
	bus_load(o);
}

/* ---- DBC ---- */
/* Value tables: state and error names, parameter names on the ids of the parameter messages. */
static void write_dbc_values(FILE *o)
{
	static const struct {
		unsigned type;
		const char *sig;
		int what; /* 0 states, 1 errors, 2 parameters */
	} vals[] = {
		{ SWELL_MSG_HEARTBEAT, "state", 0 }, { SWELL_MSG_HEARTBEAT, "err", 1 },
		{ SWELL_MSG_PARAM_SET, "id", 2 },    { SWELL_MSG_PARAM_GET, "id", 2 },
		{ SWELL_MSG_PARAM_ACK, "id", 2 },    { SWELL_MSG_PARAM_NACK, "id", 2 },
		{ SWELL_MSG_PARAM_NACK, "err", 1 },
	};
	const struct swell_param_desc *t;
	size_t i, k, n;

	fprintf(o, "\n");
	for (i = 0; i < sizeof(vals) / sizeof(vals[0]); i++) {
		fprintf(o, "VAL_ %u %s", (unsigned)SWELL_CAN_ID(vals[i].type, 0), vals[i].sig);
		if (vals[i].what == 0) {
#define SWELL_X(NAME, code, name) fprintf(o, " %d \"%s\"", code, name);
			SWELL_STATES(SWELL_X)
#undef SWELL_X
		} else if (vals[i].what == 1) {
			for (k = 0; k < SWELL_ERR_COUNT; k++)
				fprintf(o, " %u \"%s\"", (unsigned)k, swell_err_str((enum swell_err)k));
		} else {
			t = swell_param_table(&n);
			for (k = 0; k < n; k++)
				fprintf(o, " %u \"%s\"", t[k].id, t[k].name);
			fprintf(o, " %d \"%s\"", SWELL_PARAM_COMMAND_ID, SWELL_PARAM_COMMAND_NAME);
		}
		fprintf(o, " ;\n");
	}
}

static void write_dbc(FILE *o)
{
	unsigned i, j;

	fprintf(o,
		"VERSION \"swell %d\"\n\n\n"
		"NS_ :\n\tCM_\n\tBA_DEF_\n\tBA_\n\tVAL_\n\nBS_:\n\nBU_: CTL DEV VIEW\n\n\n",
		SWELL_PROTO_VERSION);
	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		fprintf(o, "BO_ %u %s: %u %s\n", (unsigned)SWELL_CAN_ID(d->type, 0), d->name, d->len, d->from);
		for (j = 0; j < d->nfields; j++) {
			const struct swell_field_desc *f = &d->fields[j];
			char lo[32], hi[32];

			phys(lo, sizeof(lo), f->min, f);
			phys(hi, sizeof(hi), f->max, f);
			fprintf(o, " SG_ %s : %u|%u@1%c (%s,0) [%s|%s] \"%s\" %s\n", f->name, f->start, f->bits,
				f->min < 0 ? '-' : '+', f->factor, lo, hi, f->unit, d->to);
		}
		fprintf(o, "\n");
	}
	fprintf(o,
		"\nCM_ \"swell wire protocol %d, generated by swell-protogen from proto_table.h; "
		"ids are for node 0, node n adds n.\";\n",
		SWELL_PROTO_VERSION);
	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		fprintf(o, "CM_ BO_ %u \"%s\";\n", (unsigned)SWELL_CAN_ID(d->type, 0), d->desc);
		for (j = 0; j < d->nfields; j++) {
			const char *s = d->fields[j].desc;

			fprintf(o, "CM_ SG_ %u %s \"", (unsigned)SWELL_CAN_ID(d->type, 0), d->fields[j].name);
			for (; *s; s++)
				fputc(*s == '"' ? '\'' : *s, o);
			fprintf(o, "\";\n");
		}
	}
	write_dbc_values(o);
}

/* ---- test vectors ---- */
static int write_vectors(FILE *o, unsigned count)
{
	unsigned i, k, j;

	fprintf(o, "# swell-protogen test vectors: id(hex) data(hex) then name=physical value per field\n");
	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		for (k = 0; k < count; k++) {
			struct swell_msg m;
			uint32_t id;
			uint8_t data[8], len;

			random_msg(d, &m, k < 2 ? (int)k : 2);
			if (swell_can_encode(&m, &id, data, &len) != SWELL_OK) {
				fprintf(stderr, "swell-protogen: encoder refused a valid %s\n", d->name);
				return 1;
			}
			fprintf(o, "%03X ", (unsigned)id);
			for (j = 0; j < len; j++)
				fprintf(o, "%02X", data[j]);
			for (j = 0; j < d->nfields; j++) {
				char v[32];

				phys(v, sizeof(v), swell_msg_field_get(&m, &d->fields[j]), &d->fields[j]);
				fprintf(o, " %s=%s", d->fields[j].name, v);
			}
			fprintf(o, "\n");
		}
	}
	return 0;
}

/* ---- fuzz seeds ---- */
static int put_file(const char *dir, const char *sub, unsigned n, const uint8_t *b, size_t len)
{
	char path[1024];
	FILE *f;

	snprintf(path, sizeof(path), "%s/%s", dir, sub);
	if (mkdir(path, 0777) && errno != EEXIST)
		return -1;
	snprintf(path, sizeof(path), "%s/%s/seed-%03u", dir, sub, n);
	f = fopen(path, "wb");
	if (!f)
		return -1;
	fwrite(b, 1, len, f);
	return fclose(f);
}

/* Fuzz input layouts: can and canfd: 2-byte id (little-endian) then the data; pkt: a mode byte
 * (bit 0: the harness fixes the CRC) then the packet. */
static int write_corpus(const char *dir)
{
	struct swell_msg all[64];
	unsigned i, n = 0, s = 0;
	uint8_t buf[2 + 64];

	if (mkdir(dir, 0777) && errno != EEXIST)
		return -1;
	for (i = 0; i < swell_msg_desc_count; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];
		struct swell_msg batch[SWELL_CANFD_MSGS_MAX];
		uint32_t id;
		uint8_t len;
		size_t used, k;

		random_msg(d, &all[n], 2);
		swell_can_encode(&all[n], &id, buf + 2, &len);
		buf[0] = (uint8_t)id;
		buf[1] = (uint8_t)(id >> 8);
		if (put_file(dir, "can", i, buf, 2u + len))
			return -1;
		for (k = 0; k < SWELL_CANFD_MSGS_MAX; k++)
			random_msg(d, &batch[k], 2);
		swell_canfd_encode(batch, 3, &id, buf + 2, &len, &used);
		buf[0] = (uint8_t)id;
		buf[1] = (uint8_t)(id >> 8);
		if (put_file(dir, "canfd", i, buf, 2u + len))
			return -1;
		n++;
	}
	for (i = 0; i < n; i += 3) {
		size_t len, used;

		buf[0] = 1;
		if (swell_pkt_encode((uint8_t)(i % 16), (uint8_t)i, &all[i], n - i, buf + 1, 64, &len, &used))
			return -1;
		if (put_file(dir, "pkt", s++, buf, len + 1))
			return -1;
	}
	return 0;
}

/* ---- the Python package's tables (host/python/swell/_tables.py) ---- */
static void py_str(FILE *o, const char *s)
{
	fputc('"', o);
	for (; *s; s++) {
		if (*s == '"' || *s == '\\')
			fputc('\\', o);
		fputc(*s, o);
	}
	fputc('"', o);
}

static void write_python(FILE *o)
{
	static const char *const kinds[] = { "PLAIN", "SEQ", "VERSION" };
	static const char *const whens[] = { "any", "dry", "idle" };
	const struct swell_param_desc *t;
	size_t n, i;
	unsigned k;

	fputs("# Generated by swell-protogen --python from swell/proto_table.h, swell/param_table.h and\n"
	      "# swell/err.h: do not edit. The codecs in this package read every layout from here.\n\n",
	      o);
	fprintf(o, "PROTO_VERSION = %u\nH_SHIFT = %u\nTILE = %u\nNODE_MAX = %u\n", (unsigned)SWELL_PROTO_VERSION,
		(unsigned)SWELL_PROTO_H_SHIFT, (unsigned)SWELL_PROTO_TILE, SWELL_NODE_MAX);
	fprintf(o, "PKT_MAGIC = 0x%02X\nPKT_HEADER = %u\nPKT_MAX = %u\n", SWELL_PKT_MAGIC, SWELL_PKT_HEADER,
		SWELL_PKT_MAX);
	fprintf(o, "UDP_HOST = \"%s\"\nUDP_PORT_DEVICE = %u\nUDP_PORT_VIEWER = %u\nUDP_PORT_CLIENTS = %u\n",
		SWELL_UDP_HOST, SWELL_UDP_PORT_DEVICE, SWELL_UDP_PORT_VIEWER, SWELL_UDP_PORT_CLIENTS);
	fprintf(o, "UDP_PORT_TOOLS_FIRST = %u\nUDP_PORT_TOOLS_COUNT = %u\nUDP_KEEPALIVE_MS = %u\n",
		SWELL_UDP_PORT_TOOLS_FIRST, SWELL_UDP_PORT_TOOLS_COUNT, SWELL_UDP_KEEPALIVE_MS);
	fprintf(o, "UDP_CLIENT_SILENT_MS = %u\nUSB_VID = 0x%04X\nUSB_PID = 0x%04X\n", SWELL_UDP_CLIENT_SILENT_MS,
		SWELL_USB_VID, SWELL_USB_PID);
	fprintf(o, "PARAM_COMMAND_ID = %u\n\n", (unsigned)SWELL_PARAM_COMMAND_ID);

	fputs("# (name, type, length, from, to, fields); a field is\n"
	      "# (member, start bit, bits, raw min, raw max, kind, factor, unit), physical = raw * factor\n"
	      "MESSAGES = (\n",
	      o);
	for (k = 0; k < swell_msg_desc_count; k++) {
		const struct swell_msg_desc *d = &swell_msg_descs[k];

		fprintf(o, "    (\"%s\", 0x%02X, %u, \"%s\", \"%s\", (\n", d->name, d->type, d->len, d->from, d->to);
		for (unsigned j = 0; j < d->nfields; j++) {
			const struct swell_field_desc *f = &d->fields[j];

			fprintf(o, "        (\"%s\", %u, %u, %lld, %lld, \"%s\", \"%s\", ", f->name, f->start, f->bits,
				(long long)f->min, (long long)f->max, kinds[f->kind], f->factor);
			py_str(o, f->unit);
			fputs("),\n", o);
		}
		fputs("    )),\n", o);
	}
	fputs(")\n\n# (id, name, raw min, raw max, raw default, factor, unit, read only, settable when, description)\n"
	      "PARAMS = (\n",
	      o);
	t = swell_param_table(&n);
	for (i = 0; i < n; i++) {
		fprintf(o, "    (%u, \"%s\", %ld, %ld, %ld, \"%s\", ", t[i].id, t[i].name, (long)t[i].min,
			(long)t[i].max, (long)t[i].def, t[i].factor);
		py_str(o, t[i].unit);
		fprintf(o, ", %s, \"%s\",\n     ", t[i].access == SWELL_PACCESS_RO ? "True" : "False",
			whens[t[i].when]);
		py_str(o, t[i].desc);
		fputs("),\n", o);
	}
	fputs(")\n\nCOMMANDS = {", o);
	for (int32_t c = 0; swell_command_name(c); c++)
		fprintf(o, "%s\"%s\": %d", c ? ", " : "", swell_command_name(c), (int)c);
	fputs("}\n\nSTATES = {", o);
	for (k = 0; k <= SWELL_CTL_FAULT; k++)
		fprintf(o, "%s%u: \"%s\"", k ? ", " : "", k, swell_state_name(k));
	fputs("}\n\nERRORS = {", o);
	for (k = 0; k < SWELL_ERR_COUNT; k++) {
		fprintf(o, "%s%u: ", k ? ", " : "", k);
		py_str(o, swell_err_str((enum swell_err)k));
	}
	fputs("}\n", o);
}

static int write_with(const char *path, void (*fn)(FILE *))
{
	FILE *f = fopen(path, "w");

	if (!f) {
		fprintf(stderr, "swell-protogen: cannot write %s: %s\n", path, strerror(errno));
		return 1;
	}
	fn(f);
	if (fclose(f)) {
		fprintf(stderr, "swell-protogen: error writing %s\n", path);
		return 1;
	}
	printf("swell-protogen: wrote %s\n", path);
	return 0;
}

int main(int argc, char **argv)
{
	const char *md = NULL, *params = NULL, *dbc = NULL, *vec = NULL, *corpus = NULL, *py = NULL;
	unsigned long count = 200;

	const struct swell_cli_opt opts[] = {
		SWELL_CLI_STR("--md", md),
		SWELL_CLI_STR("--params", params),
		SWELL_CLI_STR("--dbc", dbc),
		SWELL_CLI_STR("--python", py),
		SWELL_CLI_STR("--vectors", vec),
		SWELL_CLI_STR("--corpus", corpus),
		SWELL_CLI_WHOLE("--count", count, 2, 100000, "frames"),
		SWELL_CLI_WHOLE("--seed", rng_state, 1, 1e18, ""),
	};
	struct swell_cli cli = { .prog = "swell-protogen", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	if (argc < 2) {
		fputs(usage, stderr);
		return 2;
	}
	swell_cli_parse(&cli, argc, argv);
	if (md && write_with(md, write_md))
		return 1;
	if (params && write_with(params, write_params))
		return 1;
	if (dbc && write_with(dbc, write_dbc))
		return 1;
	if (py && write_with(py, write_python))
		return 1;
	if (vec) {
		FILE *f = fopen(vec, "w");

		if (!f || write_vectors(f, (unsigned)count) || fclose(f)) {
			fprintf(stderr, "swell-protogen: cannot write %s\n", vec);
			return 1;
		}
		printf("swell-protogen: wrote %s (%lu frames per message, %u messages)\n", vec, count,
		       swell_msg_desc_count);
	}
	if (corpus) {
		if (write_corpus(corpus)) {
			fprintf(stderr, "swell-protogen: cannot write the corpus in %s: %s\n", corpus, strerror(errno));
			return 1;
		}
		printf("swell-protogen: wrote fuzz seeds in %s/{can,canfd,pkt}\n", corpus);
	}
	return 0;
}
