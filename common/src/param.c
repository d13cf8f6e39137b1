#include "swell/param.h"

#include <string.h>

static const struct swell_param_desc table[] = {
#define SWELL_X(NAME, id, name, member, ctype, group, min, max, def, factor, unit, access, when, desc) \
	{ id,                                                                                          \
	  name,                                                                                        \
	  #ctype,                                                                                      \
	  SWELL_PGROUP_##group,                                                                        \
	  min,                                                                                         \
	  max,                                                                                         \
	  def,                                                                                         \
	  factor,                                                                                      \
	  unit,                                                                                        \
	  SWELL_PWHEN_##when,                                                                          \
	  SWELL_PACCESS_##access,                                                                      \
	  desc },
	SWELL_PARAMS(SWELL_X)
#undef SWELL_X
};

#define COUNT (sizeof(table) / sizeof(table[0]))

const struct swell_param_desc *swell_param_table(size_t *n)
{
	*n = COUNT;
	return table;
}

const struct swell_param_desc *swell_param_by_id(uint16_t id)
{
	for (size_t k = 0; k < COUNT; k++)
		if (table[k].id == id)
			return &table[k];
	return NULL;
}

const struct swell_param_desc *swell_param_by_name(const char *name)
{
	for (size_t k = 0; name && k < COUNT; k++)
		if (strcmp(table[k].name, name) == 0)
			return &table[k];
	return NULL;
}

static const struct {
	int32_t value;
	const char *name;
} commands[] = {
#define SWELL_X(NAME, value, name, desc) { value, name },
	SWELL_COMMANDS(SWELL_X)
#undef SWELL_X
};

const char *swell_command_name(int32_t value)
{
	for (size_t k = 0; k < sizeof(commands) / sizeof(commands[0]); k++)
		if (commands[k].value == value)
			return commands[k].name;
	return NULL;
}

int32_t swell_command_by_name(const char *name)
{
	for (size_t k = 0; name && k < sizeof(commands) / sizeof(commands[0]); k++)
		if (strcmp(commands[k].name, name) == 0)
			return commands[k].value;
	return -1;
}

const char *swell_state_name(unsigned state)
{
	static const char *const names[] = {
#define SWELL_X(NAME, code, name) [code] = name,
		SWELL_STATES(SWELL_X)
#undef SWELL_X
	};

	return state < sizeof(names) / sizeof(names[0]) ? names[state] : "?";
}

const char *swell_param_when_text(enum swell_param_when w)
{
	return w == SWELL_PWHEN_DRY     ? "not while the object displaces water"
		: w == SWELL_PWHEN_IDLE ? "not while the force law runs"
					: "any state";
}
