/* swell-tool: scene files (swell/scene.h) against a running controller. */
#ifndef SWELL_TOOL_SCENE_H
#define SWELL_TOOL_SCENE_H

#include "tool_session.h"

/* Send a scene file as one change: its solver rate must be the running controller's; a pool other
 * than the running one is set first (PARAM_SETs of pool.*, outside RUNNING, on a port that takes
 * them: swell/ctl_pool.h), shrinking changes first; then every parameter in file order. If the
 * controller refuses one, those already set are put back (in reverse order, then wave.e when the
 * pool changed it) and the line is named. Prints what changed. TOOL_OK, TOOL_USAGE (the file does
 * not parse), TOOL_REFUSED, TOOL_TIMEOUT. */
enum tool_rc tool_scene_load(struct tool_session *s, const char *path, int timeout_ms);

/* Write the scene in force: pool and solver rate (from SCENE and wave.e) and every parameter. */
enum tool_rc tool_scene_save(struct tool_session *s, const char *path, int timeout_ms);

#endif
