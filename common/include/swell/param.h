/* The parameter table (swell/param_table.h) as data, for tools, the generator and tests: look a
 * parameter up by id or by name; the names of commands and states. No allocation, no float. */
#ifndef SWELL_PARAM_H
#define SWELL_PARAM_H

#include <stddef.h>
#include <stdint.h>

#include "swell/param_table.h"
#include "swell/proto_table.h"

enum swell_param_group {
	SWELL_PGROUP_WAVE,
	SWELL_PGROUP_BODY,
	SWELL_PGROUP_SIZE,
	SWELL_PGROUP_SAFETY,
	SWELL_PGROUP_FRAME,
	SWELL_PGROUP_CORE
};
enum swell_param_access {
	SWELL_PACCESS_RW,
	SWELL_PACCESS_RO /* measured by the controller: read only, never in a scene */
};
enum swell_param_when {
	SWELL_PWHEN_ANY,
	SWELL_PWHEN_DRY,
	SWELL_PWHEN_IDLE
};

struct swell_param_desc {
	uint16_t id;
	const char *name;
	const char *ctype;
	enum swell_param_group group;
	int32_t min, max, def; /* raw */
	const char *factor; /* physical = raw x factor, exact decimal */
	const char *unit;
	enum swell_param_when when;
	enum swell_param_access access;
	const char *desc;
};

/* Every parameter in table order; *n is set to their count. */
const struct swell_param_desc *swell_param_table(size_t *n);
/* NULL when no parameter has this id or name. */
const struct swell_param_desc *swell_param_by_id(uint16_t id);
const struct swell_param_desc *swell_param_by_name(const char *name);

/* A command's name ("run") from its value, NULL for none; its value from its name, -1 for none. */
const char *swell_command_name(int32_t value);
int32_t swell_command_by_name(const char *name);

/* A controller state's name (HEARTBEAT.state, swell/proto_table.h: "running"); "?" for none. */
const char *swell_state_name(unsigned state);

/* "any state" or "not while the object displaces water" */
const char *swell_param_when_text(enum swell_param_when w);

#endif
