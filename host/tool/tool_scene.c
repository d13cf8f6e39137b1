/* swell-tool: scene files against a running controller; see tool_scene.h. */
#include "tool_scene.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "swell/param.h"
#include "swell/param_text.h"
#include "swell/scene.h"
#include "swell/wave.h"

#define G_MM_S2 9810u /* the core's gravity (not a parameter) */

/* e from eq. 2 within 1e-4 of the one in force: the same solver rate (the built-in reference e was
 * rounded once, 5e-6 away from eq. 2 with g = 9.81). */
static int same_e(q30_t a, q30_t b)
{
	const int64_t d = (int64_t)a - b;

	return (d < 0 ? -d : d) <= (int64_t)b / 10000;
}

/* The solver rate whose e (eq. 2) for this pool is e; 0 when none is. */
static uint32_t solver_hz_of(const struct tool_telemetry *t, int32_t e)
{
	uint32_t hz;

	for (hz = 1; hz <= 10000; hz++) {
		q30_t x;

		if (1000000u % hz == 0 &&
		    swell_wave_e_from_physical(G_MM_S2, 1000000u / hz, t->scene.depth_10um * 10u, t->scene.dx_um, &x) ==
			    SWELL_OK &&
		    same_e(x, e))
			return hz;
	}
	return 0;
}

/* The solver rate of the file (solver.hz without wave.e) against the controller's: a rate is a
 * start-up parameter of every port. Its line when they differ, 0 when they agree or the file is silent. */
static int rate_differs(const struct tool_session *s, const struct swell_scene *sc, int32_t e, char *why, size_t len)
{
	const struct swell_scene_value *v = swell_scene_get(sc, SWELL_SCENE_SOLVER_HZ);
	uint32_t now;

	if (!v || swell_scene_get(sc, SWELL_PARAM_WAVE_E))
		return 0;
	now = solver_hz_of(&s->t, e);
	if (now == (uint32_t)v->raw)
		return 0;
	if (now)
		snprintf(why, len,
			 "solver.hz = %ld Hz, the controller runs %lu Hz: a start-up parameter (swell-ctl --scene)",
			 (long)v->raw, (unsigned long)now);
	else
		snprintf(why, len,
			 "solver.hz = %ld Hz is not the running controller's rate (its wave.e differs): a start-up "
			 "parameter (swell-ctl --scene)",
			 (long)v->raw);
	return v->line;
}

/* One value to send: the file's, and the one in force before, to put back. */
struct step {
	const struct swell_scene_value *v;
	int32_t old;
};

/* Where a change of the pool goes in the order of sets: those that shrink the grid or lower e
 * (e = g dt^2 d / dx^2) first, those that raise e or grow the grid last, so that every pool on the
 * way is no larger than the first or the last and its e no higher than theirs (each set restarts
 * the controller with that pool). */
static int pool_rank(uint16_t id, int32_t from, int32_t to)
{
	const int grows = to > from;

	switch (id) {
	case SWELL_SCENE_NX:
	case SWELL_SCENE_NY:
		return grows ? 5 : 0;
	case SWELL_SCENE_DX_UM:
		return grows ? 1 : 4;
	default:
		return grows ? 3 : 2;
	}
}

/* The pool's values of the file that differ from the controller's, in pool_rank order, into plan. */
static size_t pool_steps(const struct tool_session *s, const struct swell_scene *sc, struct step *plan)
{
	const struct tool_telemetry *t = &s->t;
	const int32_t now[4] = { t->scene.nx, t->scene.ny, t->scene.dx_um, (int32_t)t->scene.depth_10um * 10 };
	size_t n = 0, k;
	int rank;

	for (rank = 0; rank <= 5; rank++)
		for (k = 0; k < 4; k++) {
			const uint16_t id = (uint16_t)(SWELL_SCENE_NX + k);
			const struct swell_scene_value *v = swell_scene_get(sc, id);

			if (v && v->raw != now[k] && pool_rank(id, now[k], v->raw) == rank)
				plan[n++] = (struct step){ v, now[k] };
		}
	return n;
}

/* Put back plan[0 .. done), newest first (each earlier state was accepted, so each step back is
 * too), then wave.e when a pool set changed it by eq. 2. */
static enum tool_rc put_back(struct tool_session *s, const struct step *plan, size_t done, int32_t e, int timeout_ms)
{
	enum swell_err why = SWELL_OK;
	char err[200];
	int32_t now = 0;
	enum tool_rc rc = TOOL_OK;
	int pool = 0;

	while (rc == TOOL_OK && done-- > 0) {
		pool |= swell_scene_key(plan[done].v->d->id) != NULL;
		rc = tool_request(s, 1, plan[done].v->d->id, plan[done].old, timeout_ms, &now, &why, err, sizeof(err));
		if (rc != TOOL_OK)
			fprintf(stderr,
				"swell-tool: scene load: could not put %s back (%s): the controller is part changed\n",
				plan[done].v->d->name, rc == TOOL_REFUSED ? swell_err_str(why) : err);
	}
	if (rc == TOOL_OK && pool) {
		rc = tool_request(s, 1, SWELL_PARAM_WAVE_E, e, timeout_ms, &now, &why, err, sizeof(err));
		if (rc != TOOL_OK)
			fprintf(stderr, "swell-tool: scene load: could not put wave.e back (%s)\n",
				rc == TOOL_REFUSED ? swell_err_str(why) : err);
	}
	return rc;
}

/* 0 when the controller takes a new pool (it answers a get of pool.nx); else the refusal on one line. */
static int takes_pool(struct tool_session *s, const struct step *first, int timeout_ms, char *why, size_t len)
{
	enum swell_err no = SWELL_OK;
	char err[200], a[48], b[48];
	int32_t v = 0;
	enum tool_rc rc = tool_request(s, 0, SWELL_SCENE_NX, 0, timeout_ms, &v, &no, err, sizeof(err));

	if (rc == TOOL_OK)
		return 0;
	swell_param_format(first->v->d, first->v->raw, a, sizeof(a));
	swell_param_format(first->v->d, first->old, b, sizeof(b));
	snprintf(why, len,
		 "%s = %s, the controller runs %s and takes no new pool (%s): a start-up parameter "
		 "(swell-ctl --scene)",
		 first->v->d->name, a, b, rc == TOOL_REFUSED ? swell_err_str(no) : err);
	return first->v->line;
}

/* A value of the file that may change only while the object is out of the water (mass, size,
 * damper) and differs from the one in force. */
static int dry_change(const struct swell_scene_value *v, int32_t old)
{
	return v->d->when == SWELL_PWHEN_DRY && v->raw != old;
}

/* The plan: the file's parameters with the values in force (to put back if a later line is refused),
 * the dry changes first, before a new pool can put the object into water at rest; then the pool's
 * steps; then the other parameters, each group in file order. *n is the plan's length. */
static enum tool_rc plan_steps(struct tool_session *s, const struct swell_scene *sc, const struct step *pool,
			       size_t npool, struct step *plan, size_t *n, int timeout_ms)
{
	int32_t old[SWELL_SCENE_PARAMS_MAX] = { 0 };
	size_t k;

	for (k = 0; k < sc->n; k++) {
		const enum tool_rc rc = swell_scene_key(sc->v[k].d->id)
			? TOOL_OK
			: tool_get(s, sc->v[k].d, timeout_ms, &old[k], "scene load");

		if (rc != TOOL_OK)
			return rc;
	}
	*n = 0;
	for (k = 0; k < sc->n; k++)
		if (!swell_scene_key(sc->v[k].d->id) && dry_change(&sc->v[k], old[k]))
			plan[(*n)++] = (struct step){ &sc->v[k], old[k] };
	for (k = 0; k < npool; k++)
		plan[(*n)++] = pool[k];
	for (k = 0; k < sc->n; k++)
		if (!swell_scene_key(sc->v[k].d->id) && !dry_change(&sc->v[k], old[k]))
			plan[(*n)++] = (struct step){ &sc->v[k], old[k] };
	return TOOL_OK;
}

enum tool_rc tool_scene_load(struct tool_session *s, const char *path, int timeout_ms)
{
	struct swell_scene sc;
	struct step pool_part[4], plan[SWELL_SCENE_PARAMS_MAX];
	int32_t e = 0, now = 0;
	char err[400], a[48], b[48];
	size_t k, n, pool, done = 0, changed = 0;
	enum swell_err why = SWELL_OK;
	enum tool_rc rc;
	int line;

	if (swell_scene_load(path, &sc, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-tool: scene load: %s; nothing sent\n", err);
		return TOOL_USAGE;
	}
	rc = tool_wait_full(s, 11 * timeout_ms / 10 + 1200);
	if (rc == TOOL_OK)
		rc = tool_get(s, swell_param_by_id(SWELL_PARAM_WAVE_E), timeout_ms, &e, "scene load");
	if (rc != TOOL_OK)
		return rc;
	line = rate_differs(s, &sc, e, err, sizeof(err));
	pool = pool_steps(s, &sc, pool_part);
	if (!line && pool)
		line = takes_pool(s, &pool_part[0], timeout_ms, err, sizeof(err));
	if (line) {
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s; nothing changed\n", path, line, err);
		return TOOL_REFUSED;
	}
	rc = plan_steps(s, &sc, pool_part, pool, plan, &n, timeout_ms);
	if (rc != TOOL_OK)
		return rc;
	if (n > 0 && dry_change(plan[0].v, plan[0].old) && tool_object_wet(s)) {
		swell_param_format(plan[0].v->d, plan[0].v->raw, a, sizeof(a));
		fprintf(stderr,
			"swell-tool: scene load: %s:%d: %s = %s: not while the object displaces water (state %s): "
			"lift it out first; nothing changed\n",
			path, plan[0].v->line, plan[0].v->d->name, a, swell_state_name(s->t.hb.state));
		return TOOL_REFUSED;
	}
	for (k = 0; k < n; k++) {
		rc = tool_request(s, 1, plan[k].v->d->id, plan[k].v->raw, timeout_ms, &now, &why, err, sizeof(err));
		if (rc != TOOL_OK)
			break;
		done = k + 1;
		changed += now != plan[k].old;
	}
	if (rc == TOOL_OK) {
		printf("scene load %s: %zu values, %zu changed%s, state %s\n", path, sc.n, changed,
		       pool ? " (a new pool: the controller restarted, the water at rest)" : "",
		       swell_state_name(s->t.hb.state));
		for (k = 0; k < n; k++) {
			if (plan[k].old == plan[k].v->raw)
				continue;
			swell_param_format(plan[k].v->d, plan[k].old, a, sizeof(a));
			swell_param_format(plan[k].v->d, plan[k].v->raw, b, sizeof(b));
			printf("  %-18s %s -> %s\n", plan[k].v->d->name, a, b);
		}
		return TOOL_OK;
	}
	if (rc == TOOL_REFUSED)
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s refused by the controller: %s (state %s)\n", path,
			plan[k].v->line, plan[k].v->d->name, swell_err_str(why), swell_state_name(s->t.hb.state));
	else
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s: %s\n", path, plan[k].v->line, plan[k].v->d->name,
			err);
	if (put_back(s, plan, done, e, timeout_ms) != TOOL_OK)
		return rc;
	if (rc == TOOL_REFUSED)
		fprintf(stderr,
			"swell-tool: scene load: every value set before line %d was put back; the controller "
			"is as it was\n",
			plan[k].v->line);
	return rc;
}

enum tool_rc tool_scene_save(struct tool_session *s, const char *path, int timeout_ms)
{
	const struct swell_param_desc *t;
	struct swell_scene sc;
	char head[200];
	size_t n, k;
	int32_t v = 0;
	uint32_t hz;
	enum tool_rc rc = tool_wait_full(s, 11 * timeout_ms / 10 + 1200);
	FILE *f;

	if (rc != TOOL_OK) {
		fprintf(stderr, "swell-tool: scene save: no scene description from the controller\n");
		return rc;
	}
	memset(&sc, 0, sizeof(sc));
	swell_scene_put(&sc, SWELL_SCENE_NX, s->t.scene.nx);
	swell_scene_put(&sc, SWELL_SCENE_NY, s->t.scene.ny);
	swell_scene_put(&sc, SWELL_SCENE_DX_UM, (int32_t)s->t.scene.dx_um);
	swell_scene_put(&sc, SWELL_SCENE_DEPTH_UM, (int32_t)s->t.scene.depth_10um * 10);
	t = swell_param_table(&n);
	for (k = 0; k < n; k++) {
		if (t[k].access == SWELL_PACCESS_RO)
			continue; /* measured, not a setting */
		rc = tool_get(s, &t[k], timeout_ms, &v, "scene save");
		if (rc != TOOL_OK)
			return rc;
		if (t[k].id == SWELL_PARAM_WAVE_E && (hz = solver_hz_of(&s->t, v)) != 0)
			swell_scene_put(&sc, SWELL_SCENE_SOLVER_HZ, (int32_t)hz);
		swell_scene_put(&sc, t[k].id, v);
	}
	f = fopen(path, "w");
	if (!f) {
		fprintf(stderr, "swell-tool: scene save: cannot write %s: %s\n", path, strerror(errno));
		return TOOL_FAIL;
	}
	snprintf(head, sizeof(head), "saved by swell-tool from node %d on %s (scene id %u)", s->node, s->name,
		 s->t.scene.scene_id);
	if (swell_scene_write(f, &sc, head) != 0 || fclose(f) != 0) {
		fprintf(stderr, "swell-tool: scene save: writing %s failed\n", path);
		return TOOL_FAIL;
	}
	printf("scene save %s: %zu values\n", path, sc.n);
	return TOOL_OK;
}
