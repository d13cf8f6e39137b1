/* The controller core's solver step spread over the ticks of its period, by the port's costs of its
 * parts (swell/ctl_port.h). */
#include "ctl_priv.h"

/* The solver step spread over the K ticks of its period: tick k does the momentum of its share of
 * rows (by the port's relative costs, the period's rows and its end in K equal parts: after tick
 * k < K-1 the rows that fit (k+1) parts, the rest on tick K-1 with the step's end), whose heights
 * become h(n+1) one row behind (wave.h, velocity form), and the body's ceiling scan of the rows that
 * hold h(n+1) (while the object is out of the water); tick K-1 also completes the step (the last row's heights, the fixers, the tile flags) and
 * then places the period's coupling into h(n+1). The force law in between reads h(n) and the solver's
 * change in every row (wave.h: h - dh(u) in rows below done_row), so it never sees a half-finished
 * step. */
uint32_t ctl_solver_slice(struct swell_ctl *c)
{
	struct swell_wave *w = &c->wave;
	const uint32_t done0 = w->done_row, k = c->phase, kk = c->ticks_per_step;
	const uint32_t k_cell = swell_ctl_port_costs.cell;
	/* a row's cost, and the period's: the rows and the step's end */
	const uint32_t row = w->nx * (c->body.wet ? k_cell : k_cell + swell_ctl_port_costs.scan_cell);
	const uint32_t total = row * w->ny + swell_ctl_port_costs.end;
	const uint32_t fit = k + 1 < kk ? total / kk * (k + 1) / row : w->ny;
	const uint32_t target = fit < w->ny ? fit : w->ny;
	const uint32_t rows = target > w->next_row ? target - w->next_row : 0;
	struct swell_body_fp placed;
	uint32_t work;

	swell_wave_step_rows(w, (int)rows);
	if (k + 1 < kk) {
		swell_body_scan_ahead(&c->body, w);
		work = (rows + (w->done_row - done0)) * w->nx;
	} else {
		swell_wave_step_finish(w);
		ctl_mark_moved_tiles(c);
		/* the period's coupling, kept back, into h(n+1): the tiles it wrote are stale too */
		placed = c->body.placed;
		swell_body_place(&c->body, w);
		ctl_mark_water_moved(c, &placed);
		swell_body_solver_stepped(&c->body, w);
		ctl_energy_water(c);
		c->n.solver_steps++;
		/* the rows, the last row's heights and the ceiling scan of the rows left */
		work = (rows + 2u * (w->ny - done0)) * w->nx;
	}
	c->phase = c->phase + 1 == c->ticks_per_step ? 0 : c->phase + 1;
	return work;
}
