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

static enum tool_rc get(struct tool_session *s, uint16_t id, int timeout_ms, int32_t *v, const char *what)
{
	enum swell_err why = SWELL_OK;
	char err[200];
	enum tool_rc rc = tool_request(s, 0, id, 0, timeout_ms, v, &why, err, sizeof(err));

	if (rc == TOOL_REFUSED)
		fprintf(stderr, "swell-tool: %s: get %s refused: %s\n", what, swell_param_by_id(id)->name,
			swell_err_str(why));
	else if (rc != TOOL_OK)
		fprintf(stderr, "swell-tool: %s: %s\n", what, err);
	return rc;
}

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

/* A start-up parameter of the file that differs from the running controller: its line, 0 if none. */
static int startup_differs(const struct tool_session *s, const struct swell_scene *sc, int32_t e, char *why, size_t len)
{
	const struct tool_telemetry *t = &s->t;
	const int32_t now[4] = { t->scene.nx, t->scene.ny, t->scene.dx_um, (int32_t)t->scene.depth_10um * 10 };
	const uint16_t ids[4] = { SWELL_SCENE_NX, SWELL_SCENE_NY, SWELL_SCENE_DX_UM, SWELL_SCENE_DEPTH_UM };
	const struct swell_scene_value *v;
	char a[48], b[48];
	int k;

	for (k = 0; k < 4; k++) {
		v = swell_scene_get(sc, ids[k]);
		if (v && v->raw != now[k]) {
			swell_param_format(v->d, v->raw, a, sizeof(a));
			swell_param_format(v->d, now[k], b, sizeof(b));
			snprintf(why, len, "%s = %s, the controller runs %s: a start-up parameter (swell-ctl --scene)",
				 v->d->name, a, b);
			return v->line;
		}
	}
	v = swell_scene_get(sc, SWELL_SCENE_SOLVER_HZ);
	if (v && !swell_scene_get(sc, SWELL_PARAM_WAVE_E)) {
		q30_t x = 0;

		if (1000000 % v->raw != 0 ||
		    swell_wave_e_from_physical(G_MM_S2, 1000000u / (uint32_t)v->raw, (uint32_t)now[3], (uint32_t)now[2],
					       &x) != SWELL_OK ||
		    !same_e(x, e)) {
			snprintf(why, len,
				 "solver.hz = %ld Hz is not the running controller's rate (its wave.e differs): "
				 "a start-up parameter (swell-ctl --scene)",
				 (long)v->raw);
			return v->line;
		}
	}
	return 0;
}

enum tool_rc tool_scene_load(struct tool_session *s, const char *path, int timeout_ms)
{
	struct swell_scene sc;
	int32_t old[SWELL_SCENE_PARAMS_MAX] = { 0 }, e = 0, now = 0;
	char err[400], a[48], b[48];
	size_t k, done = 0, changed = 0;
	enum swell_err why = SWELL_OK;
	enum tool_rc rc;
	int line;

	if (swell_scene_load(path, &sc, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-tool: scene load: %s; nothing sent\n", err);
		return TOOL_USAGE;
	}
	rc = tool_wait_full(s, 11 * timeout_ms / 10 + 1200);
	if (rc == TOOL_OK)
		rc = get(s, SWELL_PARAM_WAVE_E, timeout_ms, &e, "scene load");
	if (rc != TOOL_OK)
		return rc;
	line = startup_differs(s, &sc, e, err, sizeof(err));
	if (line) {
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s; nothing changed\n", path, line, err);
		return TOOL_REFUSED;
	}
	for (k = 0; k < sc.n; k++) { /* the values in force, to put back if a later line is refused */
		if (swell_scene_key(sc.v[k].d->id))
			continue;
		rc = get(s, sc.v[k].d->id, timeout_ms, &old[k], "scene load");
		if (rc != TOOL_OK)
			return rc;
	}
	for (k = 0; k < sc.n; k++) {
		const struct swell_scene_value *v = &sc.v[k];

		if (swell_scene_key(v->d->id))
			continue;
		rc = tool_request(s, 1, v->d->id, v->raw, timeout_ms, &now, &why, err, sizeof(err));
		if (rc != TOOL_OK)
			break;
		done = k + 1;
		changed += now != old[k];
	}
	if (rc == TOOL_OK) {
		printf("scene load %s: %zu values, %zu changed, state %s\n", path, sc.n, changed,
		       swell_state_name(s->t.hb.state));
		for (k = 0; k < sc.n; k++) {
			if (swell_scene_key(sc.v[k].d->id) || old[k] == sc.v[k].raw)
				continue;
			swell_param_format(sc.v[k].d, old[k], a, sizeof(a));
			swell_param_format(sc.v[k].d, sc.v[k].raw, b, sizeof(b));
			printf("  %-18s %s -> %s\n", sc.v[k].d->name, a, b);
		}
		return TOOL_OK;
	}
	if (rc == TOOL_REFUSED)
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s refused by the controller: %s (state %s)\n", path,
			sc.v[k].line, sc.v[k].d->name, swell_err_str(why), swell_state_name(s->t.hb.state));
	else
		fprintf(stderr, "swell-tool: scene load: %s:%d: %s: %s\n", path, sc.v[k].line, sc.v[k].d->name, err);
	/* put back, newest first: each earlier state was accepted, so each step back is too */
	while (done-- > 0) {
		enum tool_rc back;

		if (swell_scene_key(sc.v[done].d->id))
			continue;
		back = tool_request(s, 1, sc.v[done].d->id, old[done], timeout_ms, &now, &why, err, sizeof(err));
		if (back != TOOL_OK) {
			fprintf(stderr,
				"swell-tool: scene load: could not put %s back (%s): the controller is part "
				"changed\n",
				sc.v[done].d->name, back == TOOL_REFUSED ? swell_err_str(why) : err);
			return back;
		}
	}
	if (rc == TOOL_REFUSED)
		fprintf(stderr,
			"swell-tool: scene load: every value set before line %d was put back; the controller "
			"is as it was\n",
			sc.v[k].line);
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
		rc = get(s, t[k].id, timeout_ms, &v, "scene save");
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
