/* swell-tool: scene files (swell/scene.h) against a running controller. */
#ifndef SWELL_TOOL_SCENE_H
#define SWELL_TOOL_SCENE_H

#include "tool_session.h"

/* Send a scene file as one change: its pool and solver rate must be the running controller's (they
 * are start-up parameters); then every parameter is set in file order, and if the controller
 * refuses one, those already set are put back (in reverse order) and the line is named. Prints what
 * changed. TOOL_OK, TOOL_USAGE (the file does not parse), TOOL_REFUSED, TOOL_TIMEOUT. */
enum tool_rc tool_scene_load(struct tool_session *s, const char *path, int timeout_ms);

/* Write the scene in force: pool and solver rate (from SCENE and wave.e) and every parameter. */
enum tool_rc tool_scene_save(struct tool_session *s, const char *path, int timeout_ms);

#endif
