/* Scene files; see swell/scene.h. */
#include "swell/scene.h"

#include <errno.h>
#include <string.h>

#include "swell/param_text.h"
#include "swell/pool.h"

static const struct swell_param_desc keys[] = {
	{ SWELL_SCENE_NX, "pool.nx", "uint16_t", SWELL_PGROUP_CORE, 2, SWELL_GRID_MAX, SWELL_POOL_N, "1", "cells",
	  SWELL_PWHEN_ANY, SWELL_PACCESS_RW, "grid columns (start-up)" },
	{ SWELL_SCENE_NY, "pool.ny", "uint16_t", SWELL_PGROUP_CORE, 2, SWELL_GRID_MAX, SWELL_POOL_N, "1", "cells",
	  SWELL_PWHEN_ANY, SWELL_PACCESS_RW, "grid rows (start-up)" },
	{ SWELL_SCENE_DX_UM, "pool.dx", "uint32_t", SWELL_PGROUP_CORE, 100, 65535, SWELL_POOL_DX_UM, "0.001", "mm",
	  SWELL_PWHEN_ANY, SWELL_PACCESS_RW, "cell size (start-up)" },
	{ SWELL_SCENE_DEPTH_UM, "pool.depth", "uint32_t", SWELL_PGROUP_CORE, 10, 655350, SWELL_POOL_DEPTH_UM, "0.001",
	  "mm", SWELL_PWHEN_ANY, SWELL_PACCESS_RW, "rest depth (start-up)" },
	{ SWELL_SCENE_SOLVER_HZ, "solver.hz", "uint32_t", SWELL_PGROUP_CORE, 1, SWELL_TICK_HZ_MAX, SWELL_POOL_SOLVER_HZ,
	  "1", "Hz", SWELL_PWHEN_ANY, SWELL_PACCESS_RW, "solver rate (start-up)" },
};

const struct swell_param_desc *swell_scene_key(uint16_t id)
{
	for (size_t k = 0; k < sizeof(keys) / sizeof(keys[0]); k++)
		if (keys[k].id == id)
			return &keys[k];
	return NULL;
}

const struct swell_param_desc *swell_scene_desc_by_name(const char *name)
{
	for (size_t k = 0; k < sizeof(keys) / sizeof(keys[0]); k++)
		if (!strcmp(keys[k].name, name))
			return &keys[k];
	return swell_param_by_name(name);
}

const struct swell_scene_value *swell_scene_get(const struct swell_scene *sc, uint16_t id)
{
	for (size_t k = 0; k < sc->n; k++)
		if (sc->v[k].d->id == id)
			return &sc->v[k];
	return NULL;
}

int swell_scene_put(struct swell_scene *sc, uint16_t id, int32_t raw)
{
	const struct swell_param_desc *d = swell_scene_key(id) ? swell_scene_key(id) : swell_param_by_id(id);
	struct swell_scene_value *v = (struct swell_scene_value *)swell_scene_get(sc, id);

	if (!d || raw < d->min || raw > d->max)
		return -1;
	if (!v) {
		if (sc->n == SWELL_SCENE_PARAMS_MAX)
			return -1;
		v = &sc->v[sc->n++];
	}
	*v = (struct swell_scene_value){ d, raw, 0 };
	return 0;
}

/* Trim spaces at both ends, in place. */
static char *trim(char *s)
{
	char *e;

	while (*s == ' ' || *s == '\t')
		s++;
	e = s + strlen(s);
	while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\n' || e[-1] == '\r'))
		*--e = '\0';
	return s;
}

int swell_scene_load(const char *path, struct swell_scene *out, char *err, size_t errlen)
{
	struct swell_scene sc;
	char buf[256], why[200];
	int line = 0;
	FILE *f = fopen(path, "r");

	if (!f) {
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		return -1;
	}
	memset(&sc, 0, sizeof(sc));
	while (fgets(buf, sizeof(buf), f)) {
		const struct swell_param_desc *d;
		char *s, *eq, *hash, *name, *value;
		int32_t raw = 0;

		line++;
		if (!strchr(buf, '\n') && !feof(f)) {
			snprintf(err, errlen, "%s:%d: line longer than %zu characters", path, line, sizeof(buf) - 2);
			goto refuse;
		}
		hash = strchr(buf, '#');
		if (hash)
			*hash = '\0';
		s = trim(buf);
		if (!*s)
			continue;
		eq = strchr(s, '=');
		if (!eq) {
			snprintf(err, errlen, "%s:%d: '%s' is not 'name = value unit'", path, line, s);
			goto refuse;
		}
		*eq = '\0';
		name = trim(s);
		value = trim(eq + 1);
		d = swell_scene_desc_by_name(name);
		if (!d) {
			snprintf(err, errlen, "%s:%d: no parameter '%s'", path, line, name);
			goto refuse;
		}
		if (d->access == SWELL_PACCESS_RO) {
			snprintf(err, errlen, "%s:%d: %s is read only (the controller measures it)", path, line, name);
			goto refuse;
		}
		if (swell_scene_get(&sc, d->id)) {
			snprintf(err, errlen, "%s:%d: %s given twice (first on line %d)", path, line, name,
				 swell_scene_get(&sc, d->id)->line);
			goto refuse;
		}
		if (swell_param_parse(d, value, &raw, why, sizeof(why)) < 0) {
			snprintf(err, errlen, "%s:%d: %s", path, line, why);
			goto refuse;
		}
		if (sc.n == SWELL_SCENE_PARAMS_MAX) {
			snprintf(err, errlen, "%s:%d: more than %d values", path, line, SWELL_SCENE_PARAMS_MAX);
			goto refuse;
		}
		sc.v[sc.n++] = (struct swell_scene_value){ d, raw, line };
	}
	if (ferror(f)) {
		snprintf(err, errlen, "%s: read error", path);
		goto refuse;
	}
	fclose(f);
	*out = sc;
	return 0;
refuse:
	fclose(f);
	return -1;
}

int swell_scene_write(FILE *f, const struct swell_scene *sc, const char *header)
{
	if (header)
		fprintf(f, "# %s\n", header);
	for (size_t k = 0; k < sc->n; k++) { /* 12 digits: read back, every value rounds to the same raw one */
		const struct swell_param_desc *d = sc->v[k].d;

		fprintf(f, "%-18s = %.12g%s%s\n", d->name, swell_param_phys(d, sc->v[k].raw), d->unit[0] ? " " : "",
			d->unit);
	}
	return ferror(f) ? -1 : 0;
}
