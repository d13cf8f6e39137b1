/* The velocity form's fast kernel: one pass along a run of awake tiles of a row with the column sums
 * h(j-1) + 2 h(j) + h(j+1) of the cells left, centre and right carried in registers, so that a cell
 * costs three loads of h, a handful of adds and shifts, the product and the momentum's load and
 * store (the heights' update is the driver's, one row behind). On ARMv7E-M: SMMLAR gives u + nearest(x C / 2^32) in one instruction (SMMUL and a range
 * test when damped), SSAT #28 the saturation (the sticky Q flag, read once a run) and SMMUL the
 * damping toward zero, as in the edge-flux kernel. Same bits as swell_wave_vel_ref. */
#include "wave_priv.h"

/* An image that fixes its usual width (SWELL_WAVE_FIXED_NX) gets the kernel twice: with the width as
 * a constant for grids of that width, and with w->nx for any other (a pool chosen at start-up). */
#ifdef SWELL_WAVE_FIXED_NX
#define VEL_NX(w, fixed) ((fixed) ? SWELL_WAVE_FIXED_NX : (w)->nx)
#define VEL_FIXED(w) ((w)->nx == SWELL_WAVE_FIXED_NX)
#else
#define VEL_NX(w, fixed) ((void)(fixed), (w)->nx)
#define VEL_FIXED(w) 0
#endif

/* The new momentum of one cell from its momentum u and x = 2 L9 (wave_priv.h); c = e_eff 2^(f+1),
 * as int32 for the DSP path (it fits there) and as int64 (c64) for the portable one. */
static inline __attribute__((always_inline)) int32_t vel_cell(int32_t u, int32_t x, int32_t c, int64_t c64, int32_t f,
							      int32_t q, int damp, int dsp, uint32_t *sat)
{
	int32_t s;

#if SWELL_WAVE_DSP
	if (dsp) {
		int32_t r;

		(void)sat;
		(void)f;
		(void)c64;
		if (damp) { /* floor (SMMLA), then one up when below half the kick (s + u < 0) */
			__asm__("smmla %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(c), "r"(u));
			s += (int32_t)((uint32_t)(s + u) >> 31);
		} else {
			__asm__("smmlar %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(c), "r"(u));
		}
		s = __ssat(s, 28);
		if (damp) {
			__asm__("smmul %0, %1, %2" : "=r"(r) : "r"(s * 4), "r"(q));
			s = r - (s >> 31);
		}
		return s;
	}
#endif
	(void)dsp;
	(void)f;
	(void)c;
	if (damp) {
		s = u + (int32_t)(((int64_t)x * c64) >> 32);
		s += s + u < 0;
	} else {
		s = u + (int32_t)(((int64_t)x * c64 + ((int64_t)1 << 31)) >> 32);
	}
	if (s > SWELL_H_MAX || s < SWELL_H_MIN) {
		s = s > SWELL_H_MAX ? SWELL_H_MAX : SWELL_H_MIN;
		*sat = 1;
	}
	if (damp)
		s = (int32_t)(((int64_t)s * q) >> 30) - (s >> 31);
	return s;
}

/* One cell: the column sum of the cell's right neighbour column (sr, from its three heights; the
 * centre one is cn), the cell's value, its stores, and the register rotation. */
#define VEL_CELL(K, SR)                                                                        \
	do {                                                                                   \
		sr = (SR);                                                                     \
		s = vel_cell(u[K], sl + sr + 2 * sc - 16 * c, cf, c64, f, q, damp, dsp, &sat); \
		dh = damp ? s : (s + half + ((s >> 31) & fm)) >> f; /* damped: f = 0 */        \
		u[K] = s;                                                                      \
		tot += s;                                                                      \
		if (!damp) /* damped: dh = s, the same sum */                                  \
			tot_h += dh;                                                           \
		a_or |= s;                                                                     \
		sl = sc;                                                                       \
		sc = sr;                                                                       \
		c = cn;                                                                        \
	} while (0)

/* A run of awake tiles of row j: whole blocks of 8 cells unrolled, the rest one by one, the cell
 * at the east wall with its mirrored column. mid: a row with rows above and below (the row
 * pointers are then constant offsets of one pointer when the width is fixed). */
static inline __attribute__((always_inline)) void vel_run(struct swell_wave *w, int j, int tx0, int tx1, int damp,
							  int dsp, int mid, int fixed, int64_t *sum, int32_t *any)
{
	const int nx = VEL_NX(w, fixed), i0 = tx0 * 8, i1 = tx1 * 8 < nx ? tx1 * 8 : nx;
	const int east = i1 == nx, m = (i1 - i0) - east; /* cells whose right column exists */
	const int32_t *restrict hc = w->h + (size_t)j * nx + i0;
	const int32_t *restrict hd = mid ? hc - nx : j > 0 ? hc - nx : hc;
	const int32_t *restrict hu = mid ? hc + nx : j + 1 < w->ny ? hc + nx : hc;
	int32_t *restrict u = w->u + (size_t)j * nx + i0;
	const int32_t f = w->vel_frac, half = f ? 1 << (f - 1) : 0, fm = f ? -1 : 0, q = w->q; /* f 0: dh = s */
	const int64_t c64 = (int64_t)w->e_eff << (f + 1);
	const int32_t cf = dsp ? (int32_t)c64 : 0; /* fits int32 when dsp */
	const int w0 = i0 > 0 ? -1 : 0;
	int32_t c = hc[0], sl = hd[w0] + hu[w0] + 2 * hc[w0], sc = hd[0] + hu[0] + 2 * c, sr, cn, s;
	int32_t a_or, tot = 0, tot_h = 0, dh; /* the sums of at most 16 cells */
	int64_t run_tot = 0, run_tot_h = 0; /* the run's: up to 64 cells, beyond int32 */
	uint32_t sat = 0;
	int b, k;

#if SWELL_WAVE_DSP
	if (dsp)
		__set_saturation_occurred(0);
#endif
		/* a row with rows above and below in a grid of the fixed width: the three rows from one pointer
	 * with immediate offsets (fewer registers live in the unrolled block) */
#define VEL_DOWN(K) (mid && fixed ? hc[(K)-nx] : hd[K])
#define VEL_UP(K) (mid && fixed ? hc[(K) + nx] : hu[K])
	for (b = 0; b < m / 8; b++) {
		a_or = 0;
#pragma GCC unroll 8
		for (k = 0; k < 8; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		any[b] = a_or;
		if (b & 1) { /* 16 cells of int28 still fit int32 */
			run_tot += tot;
			run_tot_h += tot_h;
			tot = tot_h = 0;
		}
		hc += 8;
		if (!(mid && fixed)) {
			hd += 8;
			hu += 8;
		}
		u += 8;
	}
	a_or = 0;
	if (east && m % 8 == 7) { /* a whole last tile at the east wall (widths of whole tiles): unrolled too */
#pragma GCC unroll 8
		for (k = 0; k < 7; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		cn = c; /* the mirrored column beyond the east wall is the last one */
		VEL_CELL(7, sc);
	} else {
		for (k = 0; k < m % 8; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		if (east) {
			cn = c;
			VEL_CELL(k, sc);
		}
	}
	if (m % 8 || east)
		any[m / 8] = a_or;
#if SWELL_WAVE_DSP
	if (dsp)
		sat = (uint32_t)__saturation_occurred();
#endif
	w->saturations += sat;
	run_tot += tot;
	sum[0] += run_tot;
	sum[1] += damp ? run_tot : run_tot_h + tot_h;
}

#if SWELL_WAVE_DSP
/* ---- The damped row kernel in Cortex-M4 assembly ---------------------------------------------
 * Rows of a grid 64 or 128 cells wide, damped (F = 0), 64 cells a pass: the row below and the row
 * above are then at immediate offsets of the centre row (or the centre row itself, mirrored, at the
 * bottom and top walls), and LDRD/STRD move two cells at a time (three LDRD of h and one LDRD and one
 * STRD of u for two cells). The damping toward zero is one SMMLS: with D = 2^32 - 4 q (q > 2^29, so
 * D fits), s 2^32 - s D = 4 q s, so SMMLS gives floor(4 q s / 2^32) = floor(q s / 2^30) exactly, the
 * fused kernel's SMMUL of 4 s without the shift; its sign is s's, so the step toward zero is
 * r - (r >> 31). The column sums of the cell's left and centre columns (sl, sc) and the centre
 * height (c) stay in registers from pair to pair; the registers' roles alternate between two pairs
 * (A and B below), so that a block of 8 cells is A B A B and ends where it began: 29 instructions a
 * pair. No register is left for a per-tile flag or a 64-bit sum: after each block the running 32-bit
 * sum of the new momentum is stored (a sum of 16 cells, the difference of two, is exact: |16 s| <=
 * 2^31), and the sums are added in 64 bits after the row. The store pointer is also the loop's
 * counter: the blocks end when it reaches an aligned boundary.
 * A row (vel_row_*): r0 = &h(j, i0 + 1), r1 = &u(j, i0), r2 = where the block sums go, r3 = { C =
 * 2 e_eff, D, sl of column i0, the east wall: the last block mirrors column i0 + 64 }.
 * Registers: r0 h, r1 u, r2 sums, r3 the running sum, r12 C, lr D, r4-r11 the pair's. */
/* The assembly is laid out by hand, an instruction group a line: */
/* clang-format off */
/* x = 2 L9 = L + R + 2 C - 16 H (column sums L, C, R; centre height H) into X */
#define VR_X(X, L, C, R, H) \
	"add " X ", " L ", " R "\n\tadd " X ", " X ", " C ", lsl #1\n\tsub " X ", " X ", " H ", lsl #4\n\t"
/* X = the new u of a cell from x in X, its old u in U (U is spent); its sum into r3 */
#define VR_CELL(X, U) \
	"smmla " X ", " X ", r12, " U "\n\tadd " U ", " X ", " U "\n\tadd " X ", " X ", " U ", lsr #31\n\t" \
	"ssat " X ", #28, " X "\n\tsmmls " X ", " X ", lr, " X "\n\tsub " X ", " X ", " X ", asr #31\n\t" \
	"add r3, r3, " X "\n\t"
/* Two cells k, k + 1: their right columns k + 1, k + 2 (LDRD from the row below at offset DN, above
 * at UP, and the centre row, which advances), their new u (LDRD, STRD); sl, sc, c become T0, T1, T3 */
#define VR_PAIR(SL, SC, CC, T0, T1, T2, T3, T4, DN, UP) \
	"ldrd " T0 ", " T1 ", [r0, #" DN "]\n\tldrd " T2 ", " T3 ", [r0, #" UP "]\n\t" \
	"add " T0 ", " T0 ", " T2 "\n\tadd " T1 ", " T1 ", " T3 "\n\t" \
	"ldrd " T2 ", " T3 ", [r0], #8\n\tadd " T0 ", " T0 ", " T2 ", lsl #1\n\tadd " T1 ", " T1 ", " T3 ", lsl #1\n\t" \
	VR_X(SL, SL, SC, T0, CC) "ldrd " CC ", " T4 ", [r1]\n\t" VR_CELL(SL, CC) \
	VR_X(SC, SC, T0, T1, T2) VR_CELL(SC, T4) "strd " SL ", " SC ", [r1], #8\n\t"
/* The last two cells at the east wall: column k + 2 mirrors k + 1 (its sum T0 twice). A single LDR
 * reaches 255 bytes back at most: the row below by an LDRD whose second word is not used. */
#define VR_PAIR_EAST(SL, SC, CC, T0, T2, T4, DN, UP) \
	"ldrd " T0 ", " T2 ", [r0, #" DN "]\n\tldr " T2 ", [r0, #" UP "]\n\tadd " T0 ", " T0 ", " T2 "\n\t" \
	"ldr " T2 ", [r0], #8\n\tadd " T0 ", " T0 ", " T2 ", lsl #1\n\t" \
	VR_X(SL, SL, SC, T0, CC) "ldrd " CC ", " T4 ", [r1]\n\t" VR_CELL(SL, CC) \
	VR_X(SC, SC, T0, T0, T2) VR_CELL(SC, T4) "strd " SL ", " SC ", [r1], #8\n\t"
#define VR_A(DN, UP) VR_PAIR("r4", "r5", "r6", "r7", "r8", "r9", "r10", "r11", DN, UP)
#define VR_B(DN, UP) VR_PAIR("r7", "r8", "r10", "r4", "r5", "r9", "r6", "r11", DN, UP)
#define VR_BLOCK(DN, UP) VR_A(DN, UP) VR_B(DN, UP) VR_A(DN, UP) VR_B(DN, UP)
#define VR_BLOCK_EAST(DN, UP) \
	VR_A(DN, UP) VR_B(DN, UP) VR_A(DN, UP) VR_PAIR_EAST("r7", "r8", "r10", "r4", "r9", "r11", DN, UP)
/* the column sum sc of the row's first column into r5 (DN4, UP4: the offsets from r0 of its cells
 * below and above), its height c into r6 */
#define VR_FIRST(DN4, UP4)                                                               \
	"ldr r6, [r0, #-4]\n\tldrd r5, r7, [r0, #" DN4 "]\n\tldr r7, [r0, #" UP4 "]\n\t" \
	"add r5, r5, r7\n\tadd r5, r5, r6, lsl #1\n\t"
/* DN, UP the offsets in bytes of the rows below and above (0: the row itself, at a wall), DN4 and UP4
 * those of the cell left of r0 (as text: immediates) */
#define VR_ROW_FN(NAME, DN, UP, DN4, UP4)                                                                           \
	static __attribute__((naked, noinline)) void NAME(                                                          \
		const int32_t *hp __attribute__((unused)), int32_t *up __attribute__((unused)),                     \
		int32_t *ap __attribute__((unused)), const int32_t *k __attribute__((unused)))                      \
	{                                                                                                           \
		__asm__ volatile("push {r3-r11, lr}\n\tldrd r12, lr, [r3]\n\tldr r4, [r3, #8]\n\t" VR_FIRST(        \
			DN4, UP4) "movs r3, #0\n"                                                                   \
				  "1:\t" VR_BLOCK(DN, UP) "str r3, [r2], #4\n\ttst r2, #63\n\tbne 1b\n\t"           \
							  "ldr r7, [sp]\n\tldr r7, [r7, #12]\n\tcmp r7, #0\n\tbeq " \
							  "2f\n\t" VR_BLOCK_EAST(DN, UP) "str r3, [r2]\n"           \
											 "2:\tpop {r3-r11, pc}");   \
	}
VR_ROW_FN(vel_row_bottom64, "0", "256", "-4", "252")
VR_ROW_FN(vel_row_top64, "-256", "0", "-260", "-4")

/* The heights' update of the row below (rows are 64 cells): h = SSAT27(h + u), four cells an LDM of u
 * (lr), an LDM of h (r12), four ADD and SSAT and an STM; unrolled, no register left for a counter */
#define VR_ADD4                                                                                \
	"ldmia lr!, {r4, r5, r6, r7}\n\tldmia r12, {r8, r9, r10, r11}\n\t"                     \
	"add r8, r8, r4\n\tadd r9, r9, r5\n\tadd r10, r10, r6\n\tadd r11, r11, r7\n\t"         \
	"ssat r8, #27, r8\n\tssat r9, #27, r9\n\tssat r10, #27, r10\n\tssat r11, #27, r11\n\t" \
	"stmia r12!, {r8, r9, r10, r11}\n\t"
#define VR_ADD16 VR_ADD4 VR_ADD4 VR_ADD4 VR_ADD4
/* The Q flag set (a clamp): one more in k[3], Q cleared, back to label BACK */
#define VR_Q(HERE, BACK)                                                                        \
	HERE ":\tldr r8, [sp]\n\tldr r9, [r8, #12]\n\tadds r9, r9, #1\n\tstr r9, [r8, #12]\n\t" \
	     "movs r9, #0\n\tmsr APSR_nzcvq, r9\n\tb " BACK "\n"
/* The running block sums of 8 blocks (LOAD puts them in r4-r11) as four sums of 16 cells, each
 * exact, added to the 64-bit k[4], k[5]; the first sum is from 0, or with PRE from the running sum in
 * r12; POST may keep the last running sum in r12 */
#define VR_SUM8(LOAD, PRE, POST) \
	LOAD "sub r10, r11, r9\n\tsub r9, r9, r7\n\tsub r7, r7, r5\n\t" PRE POST \
	"ldr r8, [sp]\n\tldrd r4, r6, [r8, #16]\n\t" \
	"adds r4, r4, r5\n\tadc r6, r6, r5, asr #31\n\tadds r4, r4, r7\n\tadc r6, r6, r7, asr #31\n\t" \
	"adds r4, r4, r9\n\tadc r6, r6, r9, asr #31\n\tadds r4, r4, r10\n\tadc r6, r6, r10, asr #31\n\t" \
	"strd r4, r6, [r8, #16]\n\t"
/* k[2] rows of a band, each a whole row with rows above and below: the row's new u (as the row
 * kernels: its running block sums from 0 at the row's start, nx / 8 a row from r2 = an aligned
 * boundary + 4, the loop's end where the next store would reach the boundary: MASK), the row's sum
 * added to k[4], k[5] (int64, low word first: SUMS), then the heights of the row below it become
 * h(n+1) (its u are final and no later row reads its h(n): UPDATE from r12 = h, lr = u, the offsets
 * HB and UB back from r0 and r1). A row whose momentum clamped and a row whose heights clamped each
 * count one in k[3] (the Q flag, clear on entry, read after each). */
#define VR_BAND_FN(NAME, DN, UP, DN4, UP4, MASK, SUMS, HB, UB, UPDATE) \
	static __attribute__((naked, noinline)) void NAME(const int32_t *hp __attribute__((unused)), \
							  int32_t *up __attribute__((unused)), \
							  int32_t *ap __attribute__((unused)), \
							  int32_t *k __attribute__((unused))) \
	{ \
		__asm__ volatile("push {r3-r11, lr}\n\tldrd r12, lr, [r3]\n" \
				 "4:\tmovs r3, #0\n\t" VR_FIRST(DN4, UP4) "mov r4, r5\n" /* sl: the west wall */ \
				 "1:\t" VR_BLOCK(DN, UP) "str r3, [r2], #4\n\ttst r2, #" MASK "\n\tbne 1b\n\t" \
				 VR_BLOCK_EAST(DN, UP) "str r3, [r2], #4\n\t" \
				 "mrs r7, APSR\n\ttst r7, #0x8000000\n\tbne 5f\n" \
				 "6:\t" SUMS \
				 "sub r12, r0, #" HB "\n\tsub lr, r1, #" UB "\n\t" UPDATE \
				 "mrs r7, APSR\n\ttst r7, #0x8000000\n\tbne 7f\n" \
				 /* the next row */ \
				 "8:\tldr r7, [sp]\n\tldrd r12, lr, [r7]\n\tldr r8, [r7, #8]\n\tsubs r8, r8, #1\n\t" \
				 "str r8, [r7, #8]\n\tbne 4b\n\tpop {r3-r11, pc}\n" \
				 VR_Q("5", "6b") VR_Q("7", "8b")); \
	}
/* 64 cells: 8 block sums a row from a 32-byte boundary + 4, the update unrolled */
VR_BAND_FN(vel_band64, "-256", "256", "-260", "252", "31", VR_SUM8("ldmdb r2, {r4-r11}\n\t", "", ""),
	   "516", "512",
	   VR_ADD16 VR_ADD16 VR_ADD16 VR_ADD16)
/* 128 cells: the row in two halves of 64, as the C driver's runs of 8 tiles, so that a half whose
 * momentum clamped counts one; 24 words a row from a 32-byte boundary: the first half's 8 block sums,
 * a gap, the second half's 8 (the sums run on over the row), a gap to the next boundary; the update
 * a loop (r3 is free then) */
static __attribute__((naked, noinline)) void vel_band128(const int32_t *hp __attribute__((unused)),
							 int32_t *up __attribute__((unused)),
							 int32_t *ap __attribute__((unused)),
							 int32_t *k __attribute__((unused)))
{
	__asm__ volatile("push {r3-r11, lr}\n\tldrd r12, lr, [r3]\n"
			 "4:\tmovs r3, #0\n\t" VR_FIRST("-516", "508") "mov r4, r5\n" /* sl: the west wall */
			 "1:\t" VR_BLOCK("-512", "512") "str r3, [r2], #4\n\ttst r2, #31\n\tbne 1b\n\t"
			 "mrs r7, APSR\n\ttst r7, #0x8000000\n\tbne 10f\n"
			 "11:\tadd r2, r2, #4\n"
			 "2:\t" VR_BLOCK("-512", "512") "str r3, [r2], #4\n\ttst r2, #31\n\tbne 2b\n\t"
			 VR_BLOCK_EAST("-512", "512") "str r3, [r2], #4\n\t"
			 "mrs r7, APSR\n\ttst r7, #0x8000000\n\tbne 5f\n"
			 "6:\t" VR_SUM8("sub lr, r2, #68\n\tldmia lr, {r4-r11}\n\t", "", "mov r12, r11\n\t")
			 VR_SUM8("ldmdb r2, {r4-r11}\n\t", "sub r5, r5, r12\n\t", "") "add r2, r2, #28\n\t"
			 "sub r12, r0, #1028\n\tsub lr, r1, #1024\n\tmovs r3, #8\n"
			 "9:\t" VR_ADD16 "subs r3, r3, #1\n\tbne 9b\n\t"
			 "mrs r7, APSR\n\ttst r7, #0x8000000\n\tbne 7f\n"
			 "8:\tldr r7, [sp]\n\tldrd r12, lr, [r7]\n\tldr r8, [r7, #8]\n\tsubs r8, r8, #1\n\t"
			 "str r8, [r7, #8]\n\tbne 4b\n\tpop {r3-r11, pc}\n"
			 VR_Q("5", "6b") VR_Q("7", "8b") VR_Q("10", "11b"));
}
/* clang-format on */

/* Whether the assembly takes the field: damped with F = 0 (the caller checks damp) and q > 2^29 */
static int vel_m4_fits(const struct swell_wave *w)
{
	return !w->vel_frac && w->q > ((int32_t)1 << 29);
}

/* Where the running sum after block b of a band's row is, from the row's first (the 128-cell rows'
 * halves are a word apart) */
static inline int vel_m4_at(int b)
{
	return b + (b >= SWELL_WAVE_TILE);
}

/* 1 if tile b of the band's n rows (their running block sums v, stride words a row; u from the
 * tile's first cell of the first row, nx a row) has a non-zero u: the case where the first row's
 * block sums to 0 (rare in moving water, every tile in still water that is awake) */
static __attribute__((noinline)) int vel_m4_moved(const int32_t *v, int stride, const int32_t *u, int nx, int n, int b)
{
	const int at = vel_m4_at(b), before = b ? vel_m4_at(b - 1) : -1;
	uint32_t any = 0;
	int r;

	for (r = 0; r < n; r++, v += stride)
		if (v[at] != (before < 0 ? 0 : v[before]))
			return 1;
	for (r = 0; r < n; r++, u += nx) /* the block sums are all 0: the cells */
		any |= (uint32_t)(u[0] | u[1] | u[2] | u[3]) | (uint32_t)(u[4] | u[5] | u[6] | u[7]);
	return any != 0;
}

int swell_wave_vel_band_m4(struct swell_wave *w, int j0, int j1, uint8_t *trow)
{
	/* the running block sums of the rows: 8 a row at 64 cells (from a 32-byte boundary + 4), 24
	 * words a row at 128 (from a boundary) */
	int32_t sums[24 * SWELL_WAVE_TILE + 8] __attribute__((aligned(32)));
	const int nx = w->nx, n = j1 - j0, wide = nx == 128;
	int32_t *v = wide ? sums : sums + 1;
	const int stride = wide ? 24 : 8;
	int32_t k[6], prev = 0;
	int64_t tot;
	int b;

	if ((nx != 64 && !wide) || j0 < 1 || j1 >= w->ny || n < 1 || n > SWELL_WAVE_TILE || w->done_row != j0 - 1 ||
	    !vel_m4_fits(w))
		return 0;
	k[0] = (int32_t)(w->e_eff * 2);
	k[1] = (int32_t)(0u - 4u * (uint32_t)w->q);
	k[2] = n;
	k[3] = 0;
	k[4] = k[5] = 0;
	swell_q_clear();
	(wide ? vel_band128 : vel_band64)(w->h + (size_t)j0 * nx + 1, w->u + (size_t)j0 * nx, v, k);
	w->saturations += (uint32_t)k[3];
	tot = (int64_t)((uint64_t)(uint32_t)k[5] << 32 | (uint32_t)k[4]);
	w->vel_sum += tot;
	w->vel_sum_h += tot;
	for (b = 0; b < w->tiles_x; b++) { /* a tile moved: its first row's block sums to non-zero, or one of its u */
		const int32_t cur = v[vel_m4_at(b)];

		if (!(trow[b] & T_NONZERO) &&
		    (cur != prev || vel_m4_moved(v, stride, w->u + (size_t)j0 * nx + b * SWELL_WAVE_TILE, nx, n, b)))
			trow[b] |= T_NONZERO;
		prev = cur;
	}
	w->done_row = (uint16_t)(j1 - 1);
	return 1;
}

int swell_wave_vel_row_m4(struct swell_wave *w, int j, uint8_t *trow)
{
	int32_t sums[17] __attribute__((aligned(64)));
	int32_t *s = sums + 9; /* the 8th sum at the 64-byte boundary */
	const int32_t *hc = w->h + (size_t)j * 64;
	int32_t k[4];
	int64_t tot;
	int b;

	if (w->nx != 64 || (j > 0 && j + 1 < w->ny) || w->ny < 2 || !vel_m4_fits(w))
		return 0;
	k[0] = (int32_t)(w->e_eff * 2);
	k[1] = (int32_t)(0u - 4u * (uint32_t)w->q);
	k[2] = j ? hc[-64] + 2 * hc[0] + hc[0] : hc[0] + 2 * hc[0] + hc[64]; /* mirrored west, and below or above */
	k[3] = 1;
	swell_q_clear();
	(j ? vel_row_top64 : vel_row_bottom64)(hc + 1, w->u + (size_t)j * 64, s, k);
	w->saturations += swell_q_take();
	tot = (int64_t)s[1] + (int32_t)((uint32_t)s[3] - (uint32_t)s[1]) + (int32_t)((uint32_t)s[5] - (uint32_t)s[3]) +
		(int32_t)((uint32_t)s[7] - (uint32_t)s[5]); /* sums of 16 cells, exact in int32 */
	w->vel_sum += tot;
	w->vel_sum_h += tot;
	for (b = 0; b < 8; b++) /* a tile moved: its block sums to non-zero, or one of its u */
		if (!(trow[b] & T_NONZERO) &&
		    (s[b] != (b ? s[b - 1] : 0) ||
		     vel_m4_moved(s, 8, w->u + (size_t)j * 64 + b * SWELL_WAVE_TILE, 64, 1, b)))
			trow[b] |= T_NONZERO;
	return 1;
}
#endif

static inline __attribute__((always_inline)) void vel_rows(struct swell_wave *w, int j, int tx0, int tx1, int damp,
							   int64_t sum[2], int32_t *any, int fixed)
{
	const int mid = j > 0 && j + 1 < w->ny;
#if SWELL_WAVE_DSP
	const int dsp = ((int64_t)w->e_eff << (w->vel_frac + 1)) <= INT32_MAX; /* the coefficient fits */
#else
	const int dsp = 0;
#endif

	if (dsp) {
		if (mid)
			damp ? vel_run(w, j, tx0, tx1, 1, 1, 1, fixed, sum, any)
			     : vel_run(w, j, tx0, tx1, 0, 1, 1, fixed, sum, any);
		else
			damp ? vel_run(w, j, tx0, tx1, 1, 1, 0, fixed, sum, any)
			     : vel_run(w, j, tx0, tx1, 0, 1, 0, fixed, sum, any);
		return;
	}
	if (mid)
		damp ? vel_run(w, j, tx0, tx1, 1, 0, 1, fixed, sum, any)
		     : vel_run(w, j, tx0, tx1, 0, 0, 1, fixed, sum, any);
	else
		damp ? vel_run(w, j, tx0, tx1, 1, 0, 0, fixed, sum, any)
		     : vel_run(w, j, tx0, tx1, 0, 0, 0, fixed, sum, any);
}

void swell_wave_vel_fused(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any)
{
	if (VEL_FIXED(w))
		vel_rows(w, j, tx0, tx1, damp, sum, any, 1);
	else
		vel_rows(w, j, tx0, tx1, damp, sum, any, 0);
}
