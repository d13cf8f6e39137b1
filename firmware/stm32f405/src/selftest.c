#include "selftest.h"

#include "../logic/core_run.h"
#include "../logic/scene.h"
#include "app.h"
#include "boot.h"
#include "isr.h"
#include "../regs/stm32f405_periph.h"
#include "console.h"
#include "loopback.h"
#include "mem.h"
#include "safe.h"
#include "swell/scene.h"
#include "tick.h"
#include "timebase.h"

#include <string.h>

/* In SRAM (see stm32f405.ld for why not CCM). The naive loop reuses the field's storage once the
 * scene's checksum is out. */
#define ARENA_WORDS APP_ARENA_WORDS
#define wave_storage app_arena /* the scene's field, then the core's arena */
#define ctl app_ctl
static struct swell_wave wave;
#define NAIVE_N (FW_SCENE_NX * FW_SCENE_NY)
_Static_assert(2 * NAIVE_N <= FW_SCENE_WORDS, "naive buffers fit the field storage");
static int32_t *const naive_a = wave_storage;
static int32_t *const naive_b = wave_storage + NAIVE_N;

/* SysTick ticks to QEMU instructions (-icount shift=0: 1 ns each; SysTick at 168 MHz). */
#define INSN_NUM 125u
#define INSN_DEN 21u

static void put_insn(uint64_t ticks, uint64_t per)
{
	con_put_ratio(ticks * INSN_NUM, per * INSN_DEN, 2);
}

/* instructions as % of a tick at tick_hz at one instruction a cycle (168 MHz), one decimal */
static void put_pct(uint64_t systicks, uint32_t tick_hz)
{
	con_put_ratio(systicks * INSN_NUM * tick_hz * 100u, (uint64_t)INSN_DEN * 168000000u, 1);
}

/* instructions, then the text mid and them as % of a tick */
static void put_insn_pct(uint64_t systicks, const char *mid, uint32_t tick_hz)
{
	put_insn(systicks, 1);
	con_puts(mid);
	put_pct(systicks, tick_hz);
}

/* "what: reason" of a refusal, a line */
static void put_refused(const char *what, enum swell_err err)
{
	con_puts(what);
	con_puts(swell_err_str(err));
	con_putc('\n');
}

/* "s" then "nx" "x" "ny" */
static void put_size(const char *s, uint32_t nx, uint32_t ny)
{
	con_puts_u32(s, nx);
	con_putc('x');
	con_put_u64(ny);
}

/* Naive three-level 9-point step on the interior cells, int32 with a Q1.31 e/2 (the cost
 * anchor of docs/stm32f405.md: a plain loop, no flux form, no walls): h' = 2h - h_prev + e L9. */
__attribute__((noinline)) static void naive_step(int32_t *restrict prev, const int32_t *restrict h, int32_t e_half_q31)
{
	int i, j;

	for (j = 1; j < FW_SCENE_NY - 1; j++) {
		for (i = 1; i < FW_SCENE_NX - 1; i++) {
			const int32_t *c = &h[j * FW_SCENE_NX + i];
			int32_t l2 = -12 * c[0] + 2 * (c[-1] + c[1] + c[-FW_SCENE_NX] + c[FW_SCENE_NX]) +
				c[-FW_SCENE_NX - 1] + c[-FW_SCENE_NX + 1] + c[FW_SCENE_NX - 1] + c[FW_SCENE_NX + 1];
			int32_t *p = &prev[j * FW_SCENE_NX + i];
			*p = 2 * c[0] - *p + (int32_t)(((int64_t)l2 * e_half_q31 + (1 << 30)) >> 31);
		}
	}
}

static uint32_t scene_checksum;

/* The same steps split into row slices and a whole finishing pass: at a device rate of K ticks per
 * solver step, ticks 0..K-2 each do ceil(ny / (K-1)) rows and tick K-1 the finishing pass. The cost of
 * the pieces the core spreads over its period (run_core measures the core's own schedule, which also
 * finishes rows ahead); must end on the same bits. */
static int run_split(uint32_t tick_hz, uint32_t solver_hz)
{
	uint32_t k = tick_hz / solver_hz, rows = (FW_SCENE_NY + k - 2) / (k - 1), n, t;
	uint64_t t0, dt, slice_max = 0, finish_max = 0, sum = 0;
	uint32_t sum_crc;

	if (fw_scene_init(&wave, wave_storage, FW_SCENE_WORDS) != SWELL_OK)
		return 0;
	for (n = 0; n < SWELL_FW_SELFTEST_STEPS; n++) {
		for (t = 0; t + 1 < k; t++) {
			t0 = timebase_systick();
			swell_wave_step_rows(&wave, (int)rows);
			dt = timebase_systick() - t0;
			sum += dt;
			slice_max = dt > slice_max ? dt : slice_max;
		}
		t0 = timebase_systick();
		swell_wave_step_finish(&wave);
		dt = timebase_systick() - t0;
		sum += dt;
		finish_max = dt > finish_max ? dt : finish_max;
	}
	sum_crc = swell_wave_checksum(&wave);
	con_puts_u32("solver per tick at ", tick_hz);
	con_puts_u32(" Hz (", k);
	con_puts_u32(" ticks a step, ", rows);
	con_puts(" rows a slice): worst slice ");
	put_insn(slice_max, 1);
	con_puts(", finish ");
	put_insn(finish_max, 1);
	con_puts(", mean ");
	put_insn(sum, (uint64_t)SWELL_FW_SELFTEST_STEPS * k);
	con_puts(" instructions; worst tick uses ");
	put_pct(slice_max > finish_max ? slice_max : finish_max, tick_hz);
	con_puts(" % of the tick at 168 MHz; checksum ");
	con_puts(sum_crc == scene_checksum ? "identical\n" : "DIFFERS\n");
	return sum_crc == scene_checksum;
}

static int run_scene(void)
{
	uint64_t t0, dt, sum = 0, min = UINT64_MAX, max = 0, empty;
	enum swell_err err;
	uint32_t n;

	err = fw_scene_init(&wave, wave_storage, FW_SCENE_WORDS);
	if (err != SWELL_OK) {
		put_refused("selftest: scene refused: ", err);
		return 0;
	}
	con_puts_hex32("selftest: scene pool 64x64 dx 6.25 mm depth 50 mm dt 4 ms e 0x", (uint32_t)wave.p.e);
	con_puts(" (Q1.30) paper stencil, damping 0, gauss 2 mm sigma 3 cells at (32,32)\n");
	con_puts_hex32("selftest: initial checksum 0x", swell_wave_checksum(&wave));
	con_putc('\n');

	t0 = timebase_systick();
	empty = timebase_systick() - t0; /* cost of the measurement itself */
	for (n = 0; n < SWELL_FW_SELFTEST_STEPS; n++) {
		t0 = timebase_systick();
		swell_wave_step(&wave);
		dt = timebase_systick() - t0 - empty;
		sum += dt;
		min = dt < min ? dt : min;
		max = dt > max ? dt : max;
	}
	con_puts_u32("steps ", SWELL_FW_SELFTEST_STEPS);
	con_putc('\n');
	scene_checksum = swell_wave_checksum(&wave);
	con_puts_hex32("checksum 0x", scene_checksum);
	con_putc('\n');
	con_puts("volume ");
	con_put_i64(swell_wave_volume(&wave));
	con_puts(" LSB (2^-16 mm per cell)\n");
	con_puts_u32("saturations ", wave.saturations);
	con_putc('\n');
	con_puts("solver step: mean ");
	con_put_ratio(sum, SWELL_FW_SELFTEST_STEPS, 1);
	con_puts(" SysTick ticks (min ");
	con_put_u64(min);
	con_puts(", max ");
	con_put_u64(max);
	con_puts(") = ");
	put_insn(sum, SWELL_FW_SELFTEST_STEPS);
	con_puts(" instructions per step (tick at 168 MHz, 1 tick = 125/21 instructions)\n");
	con_puts("solver cell-step: ");
	put_insn(sum, (uint64_t)SWELL_FW_SELFTEST_STEPS * FW_SCENE_NX * FW_SCENE_NY);
	con_puts_u32(" instructions per cell-step (swell_wave_step, undamped, ", wave.vel_frac);
	con_puts(" fraction bits, 64x64)\n");
	return 1;
}

static int scan_matches(const struct swell_body *b0, const struct swell_wave *w);

/* The ceiling scan with the fraction bits' shift (the main scene's, undamped), on a field where the
 * momentum's negative part decides the highest value (a splash's crest would hide a wrong shift). */
static int run_scan_check(void)
{
	uint32_t n;

	if (fw_scene_init(&wave, wave_storage, FW_SCENE_WORDS) != SWELL_OK)
		return 0;
	for (n = 0; n < FW_SCENE_NX * FW_SCENE_NY; n++) {
		wave.h[n] = (int32_t)(n * 7919u % 4096u) - 2048;
		wave.u[n] = -(int32_t)(n * 104729u % 65536u);
	}
	return scan_matches(&ctl.body, &wave);
}

/* The cost scenes (logic/scene.h): instructions per cell-step over the whole grid and per
 * awake cell-step (tile rows not skipped), and the checksum the host compares. */
static int run_cost(void)
{
	uint32_t k, n;

	for (k = 0; k < FW_COST_SCENES; k++) {
		uint64_t t0, sum = 0, rows, awake;

		if (fw_cost_scene_init(&wave, wave_storage, FW_SCENE_WORDS, (enum fw_cost_scene)k) != SWELL_OK)
			return 0;
		for (n = 0; n < FW_COST_STEPS; n++) {
			t0 = timebase_systick();
			swell_wave_step(&wave);
			sum += timebase_systick() - t0;
		}
		rows = (uint64_t)FW_COST_STEPS * FW_SCENE_NY * wave.tiles_x; /* tile rows, 8 cells each */
		awake = rows - wave.tiles_skipped;
		con_puts("cost scene ");
		con_puts(fw_cost_scene_name[k]);
		con_puts(": ");
		put_insn(sum, (uint64_t)FW_COST_STEPS * FW_SCENE_NX * FW_SCENE_NY);
		con_puts(" instructions per cell-step, ");
		if (awake)
			put_insn(sum, awake * SWELL_WAVE_TILE);
		else
			con_puts("-");
		con_puts(" per awake cell-step, awake ");
		con_put_ratio(awake * 100u, rows, 1);
		con_puts_u32(" % (damped t = 0.001, 64x64, ", FW_COST_STEPS);
		con_puts_hex32(" steps) checksum 0x", swell_wave_checksum(&wave));
		con_putc('\n');
	}
	return 1;
}

/* Where the agitated step goes: the row kernels (swell_wave_step_rows) against the
 * finishing pass with the fixers (swell_wave_step_finish), instructions per cell-step. */
static int run_cost_split(void)
{
	uint64_t t0, rows = 0, fin = 0;
	uint32_t n;

	if (fw_cost_scene_init(&wave, wave_storage, FW_SCENE_WORDS, FW_COST_AGITATED) != SWELL_OK)
		return 0;
	for (n = 0; n < FW_COST_STEPS; n++) {
		t0 = timebase_systick();
		swell_wave_step_rows(&wave, FW_SCENE_NY);
		rows += timebase_systick() - t0;
		t0 = timebase_systick();
		swell_wave_step_finish(&wave);
		fin += timebase_systick() - t0;
	}
	con_puts("cost split agitated: rows ");
	put_insn(rows, (uint64_t)FW_COST_STEPS * FW_SCENE_NX * FW_SCENE_NY);
	con_puts(", finish and fixers ");
	put_insn(fin, (uint64_t)FW_COST_STEPS * FW_SCENE_NX * FW_SCENE_NY);
	con_puts(" instructions per cell-step; LSB given back ");
	con_put_u64(wave.fixed_lsb);
	con_puts_u32(" in ", FW_COST_STEPS);
	con_puts(" steps\n");
	return 1;
}

/* The damped kernel in M4 assembly against the reference kernel, both on the image, from the
 * same start, on grids 64 x 64 (the band kernel, the wall rows) and 128 x 32 (128 cells a row: two
 * passes of 64): the lowest quarter at the bounds (the momentum and the heights clamp), the rest
 * still but for two rows of the first five eighths of the last band (its tiles' first rows sum to 0:
 * the flags look further). Tiles away from both fall asleep: bands with many sleeping tiles take the
 * C kernel's runs, bands with a few are computed whole by the assembly (sleeping tiles included, so
 * it skips fewer). The fields, the tile flags and the saturations must be equal after the steps. */
#define VEL_CHECK_STEPS 12u

static void vel_check_field(struct swell_wave *w)
{
	const uint32_t nx = w->nx, ny = w->ny, tiles = nx / SWELL_WAVE_TILE;
	uint32_t n, i, j;

	for (n = 0; n < nx * ny; n++) {
		i = n % nx;
		j = n / nx;
		if (j < ny / 4) { /* alternating at the bounds */
			w->h[n] = (i + j) % 2 ? SWELL_HV_MAX : SWELL_HV_MIN + (int32_t)(n % 5u);
			w->u[n] = (i * 3 + j) % 4 ? SWELL_H_MAX - (int32_t)(n % 7u) : SWELL_H_MIN;
		} else { /* still, but two rows of the last band's first five eighths */
			w->h[n] = 0;
			w->u[n] = (j == ny - 5 || j == ny - 4) && i / SWELL_WAVE_TILE < tiles * 5 / 8
				? (int32_t)(n * 2654435761u % 20001u) - 10000
				: 0;
		}
	}
	swell_wave_set_sleep(w, 1);
}

/* One grid nx x ny, both kernels: 1 if they agree and something clamped */
static int vel_kernel_check(uint16_t nx, uint16_t ny)
{
	struct swell_wave_params p = { .damping = FW_COST_DAMPING, .stencil = SWELL_STENCIL_PAPER };
	uint32_t sum[2] = { 0, 0 }, sat[2] = { 0, 0 }, skipped[2] = { 0, 0 }, k, n;
	uint8_t tiles[FW_SCENE_NX * FW_SCENE_NY / (SWELL_WAVE_TILE * SWELL_WAVE_TILE)];
	int same_tiles = 1;

	if (swell_wave_e_from_physical(FW_SCENE_G_MM_S2, FW_SCENE_DT_US, FW_SCENE_DEPTH_UM, FW_SCENE_DX_UM, &p.e) !=
		    SWELL_OK ||
	    (uint32_t)nx * ny > FW_SCENE_NX * FW_SCENE_NY)
		return 0;
	for (k = 0; k < 2; k++) {
		if (swell_wave_init(&wave, nx, ny, wave_storage, FW_SCENE_WORDS, &p) != SWELL_OK ||
		    swell_wave_set_kernel(&wave, k ? SWELL_KERNEL_FUSED : SWELL_KERNEL_REF) != SWELL_OK)
			return 0;
		vel_check_field(&wave);
		for (n = 0; n < VEL_CHECK_STEPS; n++)
			swell_wave_step(&wave);
		sum[k] = swell_wave_checksum(&wave);
		sat[k] = wave.saturations;
		skipped[k] = wave.tiles_skipped;
		if (!k)
			memcpy(tiles, wave.tile, sizeof(tiles));
		else
			same_tiles = memcmp(tiles, wave.tile, (size_t)wave.tiles_x * wave.tiles_y) == 0;
	}
	put_size("velocity kernel check ", nx, ny);
	con_puts_u32(": ", VEL_CHECK_STEPS);
	con_puts_hex32(" clamping steps, reference 0x", sum[0]);
	con_puts_hex32(" assembly 0x", sum[1]);
	con_puts_u32(", saturations ", sat[0]);
	con_puts_u32(" and ", sat[1]);
	con_puts_u32(", tiles skipped ", skipped[0]);
	con_puts_u32(" and ", skipped[1]);
	con_puts(same_tiles ? ", tile flags equal\n" : ", tile flags DIFFER\n");
	return sum[0] == sum[1] && sat[0] == sat[1] && sat[0] > 0 && skipped[1] <= skipped[0] && skipped[0] > 0 &&
		same_tiles;
}

static int run_vel_kernel_check(void)
{
	return vel_kernel_check(FW_SCENE_NX, FW_SCENE_NY) & vel_kernel_check(2 * FW_SCENE_NX, FW_SCENE_NY / 2);
}

static void run_naive(void)
{
	uint64_t t0, sum = 0;
	uint32_t n;
	int32_t *h = naive_a, *p = naive_b, *tmp;
	int i;

	for (i = 0; i < NAIVE_N; i++) /* any data: the cost does not depend on it */
		naive_b[i] = naive_a[i] = naive_a[i] & 0xFF;
	for (n = 0; n < SWELL_FW_SELFTEST_STEPS; n++) {
		t0 = timebase_systick();
		naive_step(p, h, wave.e_eff);
		sum += timebase_systick() - t0;
		tmp = h;
		h = p;
		p = tmp;
	}
	con_puts("naive int32 9-point cell-step: ");
	put_insn(sum, (uint64_t)SWELL_FW_SELFTEST_STEPS * (FW_SCENE_NX - 2) * (FW_SCENE_NY - 2));
	con_puts(" instructions per interior cell-step (a plain int32 loop)\n");
}

/* Stand-in for the core's force path until firmware/core is linked: a spring on the height under
 * the pool centre, in 0.01 N. */
static void force_tick(void)
{
	int32_t h = wave_storage[32 * FW_SCENE_NX + 32];

	safe_force_record(0, 0, h >> 10);
}

/* The tick: TIM2 is configured for 1000 Hz and its interrupt (priority 0, the force path) is
 * pended by software TICK_RUNS times, so the vector, the priority and the per-tick cost are checked
 * deterministically. Hardware updates are only counted: QEMU 7.2's TIM2 model arms its alarm at
 * twice the elapsed virtual time (fixed in QEMU 8.2), so it cannot run a periodic tick there. */
#define TICK_RUNS 10u

static int run_tick(uint32_t tim_clk_hz)
{
	struct tick_stats st;
	uint32_t n, before;
	enum swell_err err = tick_start(tim_clk_hz, 1000, 0, force_tick);

	if (err != SWELL_OK) {
		con_puts("tick: refused\n");
		return 0;
	}
	tick_read(&st);
	before = st.count;
	for (n = 0; n < TICK_RUNS; n++) {
		NVIC->ISPR[IRQ_TIM2 / 32] = 1u << (IRQ_TIM2 % 32);
		__asm__ volatile("dsb\n\tisb" ::: "memory"); /* taken here, before the next line */
	}
	tick_read(&st);
	tick_stop();
	con_puts_u32("tick: TIM2 1000 Hz from ", tim_clk_hz);
	con_puts_u32(" Hz, priority 0: ", st.count - before);
	con_puts_u32(" of ", TICK_RUNS);
	con_puts_u32(" pended interrupts taken, ", before);
	con_puts(" hardware updates; force-path stub ");
	put_insn(st.max_cost, 1);
	con_puts_u32(" instructions per tick (max), overruns ", st.overruns);
	con_putc('\n');
	return st.count - before == TICK_RUNS && st.overruns == 0;
}

#ifndef SWELL_FW_CORE_TICKS
#define SWELL_FW_CORE_TICKS 2500u
#endif
#define CORE_MAX_K 10u
#define SELFTEST_POOL_N 128u /* the larger pool's side: u alone in the fast block */

/* "core" at 2500 Hz and "core1000" at 1000 Hz on the reference pool (the qemu-arm test compares them
 * with swell-fw-scene --core), "pool96x96" on another pool; then " at 2500 Hz" for the figures. */
static void put_core_label(uint32_t tick_hz, uint16_t pool_n, int at)
{
	if (pool_n)
		put_size("pool", pool_n, pool_n);
	else if (tick_hz != 2500u && !at)
		con_puts_u32("core", tick_hz);
	else
		con_puts("core");
	if (at) {
		con_puts_u32(" at ", tick_hz);
		con_puts(" Hz");
	}
}

/* A PARAM_SET of a start-up parameter through the port's path (swell/ctl_pool.h), as the host sends it:
 * 1 when the answer is the one expected (ACK with the value, or NACK with want_err), printed. */
static int pool_set(uint16_t id, const char *name, int32_t value, enum swell_err want_err)
{
	struct swell_msg set = { .type = SWELL_MSG_PARAM_SET }, ans;
	struct fw_pool_at place;
	uint16_t nx = ctl.cfg.nx, ny = ctl.cfg.ny;
	int ok;

	set.u.param_set.id = id;
	set.u.param_set.value = value;
	set.u.param_set.seq = 7;
	if (!fw_pool_param(&ctl, &app_mem, &set, &ans, &place))
		return 0;
	con_puts("pool: set ");
	con_puts(name);
	con_putc(' ');
	con_put_i64(value);
	con_puts(" in ");
	con_puts(swell_ctl_state_name(ctl.state));
	if (ans.type == SWELL_MSG_PARAM_ACK) {
		put_size(": ACK, pool now ", ctl.cfg.nx, ctl.cfg.ny);
		con_putc('\n');
		mem_report(&ctl, &app_mem, &place);
		return want_err == SWELL_OK && ans.u.param_ack.value == value && ans.u.param_ack.seq == 7;
	}
	ok = want_err == (enum swell_err)ans.u.param_nack.err && ctl.cfg.nx == nx && ctl.cfg.ny == ny;
	con_puts(": NACK ");
	con_puts(swell_err_str((enum swell_err)ans.u.param_nack.err));
	put_size(", pool still ", ctl.cfg.nx, ctl.cfg.ny);
	con_puts(ok ? "\n" : " (UNEXPECTED)\n");
	return ok;
}

/* The pool chosen at start-up: 128 x 64 fits (whole in SRAM), 128 x 136 does not (u would need more
 * than the fast block: refused, nothing changed), then pool_n x pool_n (128 x 128: u alone in the fast
 * block). */
static int choose_pool(uint16_t pool_n)
{
	int ok = 1;

	ok &= pool_set(SWELL_SCENE_NX, "pool.nx", 128, SWELL_OK);
	ok &= pool_set(SWELL_SCENE_NY, "pool.ny", 136, SWELL_ESIZE);
	ok &= pool_set(SWELL_SCENE_NX, "pool.nx", pool_n, SWELL_OK);
	ok &= pool_set(SWELL_SCENE_NY, "pool.ny", pool_n, SWELL_OK);
	return ok;
}

/* A window for a trace of one tick (tools/bench/m4-tick-trace.sh): a debugger writes the tick's rate
 * and index here once the image has started, and breaks on the two marks, which run around that
 * tick's force and background parts only. */
volatile uint32_t selftest_trace_hz, selftest_trace_tick = UINT32_MAX;

__attribute__((noinline)) void selftest_trace_begin(void)
{
	__asm__ volatile("" ::: "memory");
}

__attribute__((noinline)) void selftest_trace_end(void)
{
	__asm__ volatile("" ::: "memory");
}

/* The body's ceiling scan (LDM assembly on this core, one variant for each shift) against a plain
 * loop on a field: the highest of h and h - floor(u / 2^F) (the solver's own change
 * before its rounding, swell/wave.h), and sum(h). On a copy of the body, so a run is untouched. */
static int scan_matches(const struct swell_body *b0, const struct swell_wave *w)
{
	struct swell_body b = *b0;
	int32_t top = INT32_MIN;
	int64_t sum = 0;
	int a, ok;

	for (a = 0; a < w->nx * w->ny; a++) {
		const int32_t d = w->u[a] >> w->vel_frac, p = w->h[a] - (d < 0 ? d : 0);

		top = p > top ? p : top;
		sum += w->h[a];
	}
	swell_body_rescan(&b, w);
	ok = b.ceiling_lsb == top && b.water_sum == sum;
	con_puts(ok ? "ceiling scan: matches the plain loop\n" : "ceiling scan: DIFFERS from the plain loop\n");
	return ok;
}

/* The controller core on the reference scene with the scripted device, its two parts measured apart
 * as the port runs them: the force part (the TIM2 interrupt) and the background part (thread mode,
 * solver slice and telemetry). Under QEMU the tick timer cannot run periodically (see run_tick), so
 * an overrun is counted where force + background exceed the period at one instruction a cycle: on
 * the board that background would still run when the next interrupt comes. */
static int run_core(uint32_t tick_hz, uint32_t ticks, uint16_t pool_n)
{
	struct fw_core_run r;
	uint64_t t0, t1, t2, empty, f, b, sum = 0, fmax = 0, bmax = 0, wmax = 0;
	uint64_t bphase[CORE_MAX_K] = { 0 };
	const uint64_t period_num = (uint64_t)INSN_DEN * 168000000u; /* period in SysTick ticks * INSN_NUM * tick_hz */
	uint32_t n, k, phase, overruns = 0, bworst_phase = 0, wworst_tick = 0;
	enum swell_err err = fw_core_init(&ctl, &r, wave_storage, ARENA_WORDS, tick_hz);

	if (err != SWELL_OK) {
		put_refused("core: refused: ", err);
		return 0;
	}
	if (!pool_n && tick_hz == 2500u) { /* the reference pool, where the controller's start puts it */
		struct fw_pool_at at;

		if (fw_pool_place(ctl.cfg.nx, ctl.cfg.ny, &app_mem, &at) != SWELL_OK || at.apart)
			return 0;
		mem_report(&ctl, &app_mem, &at);
	}
	if (pool_n && !choose_pool(pool_n))
		return 0;
	t0 = timebase_systick();
	empty = timebase_systick() - t0; /* cost of the measurement itself */
	for (n = 0; n < ticks; n++) {
		fw_core_device(&ctl, &r);
		phase = ctl.phase; /* the solver phase this tick's background part runs */
		if (n == selftest_trace_tick && tick_hz == selftest_trace_hz)
			selftest_trace_begin();
		t0 = timebase_systick();
		swell_ctl_tick_force(&ctl);
		t1 = timebase_systick();
		swell_ctl_tick_background(&ctl);
		t2 = timebase_systick();
		if (n == selftest_trace_tick && tick_hz == selftest_trace_hz)
			selftest_trace_end();
		fw_core_drain(&ctl, &r);
		f = t1 - t0 - empty;
		b = t2 - t1 - empty;
		sum += f + b;
		fmax = f > fmax ? f : fmax;
		if (f + b > wmax) {
			wmax = f + b;
			wworst_tick = n;
		}
		if (b > bmax) {
			bmax = b;
			bworst_phase = phase;
		}
		if (phase < CORE_MAX_K && b > bphase[phase])
			bphase[phase] = b;
		if ((f + b) * INSN_NUM * tick_hz > period_num)
			overruns++;
	}
	/* "core" at 2500 Hz (the qemu-arm test compares it with swell-fw-scene --core), "core<hz>" else */
	put_core_label(tick_hz, pool_n, 0);
	con_puts_u32(" ticks ", ticks);
	con_putc('\n');
	put_core_label(tick_hz, pool_n, 0);
	con_puts_hex32(" checksum 0x", fw_core_checksum(&ctl, &r));
	con_putc('\n');
	con_puts("core: state ");
	con_puts(swell_ctl_state_name(ctl.state));
	con_puts_u32(", ", r.force_cmds);
	con_puts_u32(" FORCE_CMD, ", r.host_msgs);
	con_puts(" host messages, last fz ");
	con_put_i64(r.last_fz_uN);
	con_puts_u32(" uN, solver steps ", ctl.n.solver_steps);
	con_putc('\n');
	{
		struct swell_energy_account e;

		(void)swell_ctl_energy(&ctl, &e);
		con_puts("core: energy created ");
		con_put_i64(e.created_uJ);
		con_puts_u32(" uJ, passivity controller on ", e.controller_ticks);
		con_puts(" ticks\n");
	}
	put_core_label(tick_hz, pool_n, 1);
	con_puts(": worst background ");
	put_insn_pct(bmax, " instructions (", tick_hz);
	con_puts_u32(" % of the period, phase ", bworst_phase);
	con_puts("), worst force path ");
	put_insn_pct(fmax, " (", tick_hz);
	con_puts(" %), worst whole tick ");
	put_insn_pct(wmax, " (", tick_hz);
	con_puts_u32(" %) at tick ", wworst_tick);
	con_puts(", mean ");
	put_insn(sum, ticks);
	con_puts_u32("; overruns ", overruns);
	con_putc('\n');
	put_core_label(tick_hz, pool_n, 1);
	con_puts(": worst background by solver phase (instructions):");
	for (k = 0; k < CORE_MAX_K && k < ctl.ticks_per_step; k++) {
		con_putc(' ');
		put_insn(bphase[k], 1);
	}
	con_putc('\n');
	/* a deadline missed on the reference scene is a failure, not a figure */
	return scan_matches(&ctl.body, &ctl.wave) && ctl.state == SWELL_CTL_RUNNING && r.force_cmds == ticks &&
		overruns == 0;
}

int selftest_run(uint32_t tim_clk_hz)
{
	int ok = 1;

	con_puts("selftest: begin (no CAN, no USB answered: loopback link)\n");
	ok &= run_scene();
	ok &= run_split(2500, 250); /* HapticMaster servo rate */
	ok &= run_split(1000, 250); /* classic CAN */
	ok &= run_scan_check();
	ok &= run_cost();
	ok &= run_cost_split();
	ok &= run_vel_kernel_check();
	run_naive();
	ok &= run_tick(tim_clk_hz);
	ok &= loopback_selftest();
	ok &= run_core(2500, SWELL_FW_CORE_TICKS, 0); /* HapticMaster servo rate, device on USB */
	ok &= run_core(1000, SWELL_FW_CORE_TICKS * 2 / 5, 0); /* classic CAN, the same 1 s */
	ok &= run_core(2500, SWELL_FW_CORE_TICKS, SELFTEST_POOL_N); /* a larger pool chosen at start-up */
	con_puts_u32("stack: ", stack_used_bytes());
	con_puts_u32(" of ", stack_size_bytes());
	con_puts(" bytes used; console: ");
	con_put_u64(con_dropped()); /* counted before this line is written */
	con_puts(" characters dropped\n");
	con_puts(ok ? "selftest: end ok\n" : "selftest: end FAILED\n");
	return ok;
}

/* Boot mode "bootloader" (QEMU): the enter-bootloader path as far as it goes without a ROM. The core
 * on the reference scene in RUNNING with the object pressed in must refuse ENTER_BOOTLOADER; once
 * stopped (autorun off: ARMED) it must accept it with the force zero; then the same call as on a
 * board (boot_request_reset: line, magic, system reset). */
void selftest_boot_request(void)
{
	struct fw_core_run r;
	struct swell_msg req = { .type = SWELL_MSG_ENTER_BOOTLOADER }, stop = { .type = SWELL_MSG_PARAM_SET };
	int32_t f_running;
	uint32_t n;

	struct swell_msg info[8]; /* the first tick queues the heartbeat, then CTL_INFO */
	size_t k, got;

	if (fw_core_init(&ctl, &r, wave_storage, ARENA_WORDS, 2500) != SWELL_OK) {
		con_puts("boot test: core refused its configuration\n");
		return;
	}
	app_fw_version(ctl.cfg.fw_version); /* as app_run does */
	fw_core_device(&ctl, &r);
	swell_ctl_tick(&ctl);
	got = swell_ctl_tx(&ctl, SWELL_LINK_HOST, info, sizeof(info) / sizeof(info[0]));
	for (k = 0; k < got && info[k].type != SWELL_MSG_CTL_INFO; k++)
		;
	con_puts("boot test: CTL_INFO at the first tick: ");
	if (k == got) {
		con_puts("NONE\n");
		return;
	}
	con_put_u64(info[k].u.ctl_info.fw_major);
	con_putc('.');
	con_put_u64(info[k].u.ctl_info.fw_minor);
	con_putc('.');
	con_put_u64(info[k].u.ctl_info.fw_patch);
	con_putc('\n');
	fw_core_drain(&ctl, &r);
	for (n = 0; n < 1250; n++) { /* 0.5 s: the object pressed 5 mm into the water */
		fw_core_device(&ctl, &r);
		swell_ctl_tick(&ctl);
		fw_core_drain(&ctl, &r);
	}
	f_running = ctl.force_dev_uN[2];
	req.u.enter_bootloader.key = SWELL_PROTO_BOOT_KEY;
	swell_ctl_rx(&ctl, SWELL_LINK_HOST, &req);
	con_puts("boot test: ENTER_BOOTLOADER in ");
	con_puts(swell_ctl_state_name(ctl.state));
	con_puts(" (force z ");
	con_put_i64(f_running);
	con_puts(" uN): ");
	con_puts(swell_ctl_bootloader_requested(&ctl) ? "ACCEPTED\n" : "refused\n");
	if (swell_ctl_bootloader_requested(&ctl))
		return;
	stop.u.param_set.id = SWELL_PARAM_AUTORUN;
	stop.u.param_set.value = 0;
	swell_ctl_rx(&ctl, SWELL_LINK_HOST, &stop);
	fw_core_device(&ctl, &r);
	swell_ctl_tick(&ctl);
	fw_core_drain(&ctl, &r);
	swell_ctl_rx(&ctl, SWELL_LINK_HOST, &req);
	fw_core_drain(&ctl, &r);
	con_puts("boot test: ENTER_BOOTLOADER in ");
	con_puts(swell_ctl_state_name(ctl.state));
	con_puts(": ");
	con_puts(swell_ctl_bootloader_requested(&ctl) ? "accepted" : "REFUSED");
	con_puts(", force now");
	for (k = 0; k < 3; k++) {
		con_putc(' ');
		con_put_i64(ctl.force_dev_uN[k]);
	}
	con_puts(" uN\n");
	if (swell_ctl_bootloader_requested(&ctl))
		boot_request_reset();
}
