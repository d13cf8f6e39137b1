/* swell-view rendering, see render.h. World frame: metres, pool from (0, 0) to (Lx, Ly), z up, the
 * rest surface at z = 0, the floor at z = -depth. */
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include "render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "canvas.h"
#include "swell/pool.h"

#define PI_F 3.14159265f

/* Light from +x, a little +y, above: the test pictures rely on the +x flank of a bump being the lit one. */
static const float light_dir[3] = { 0.62f, 0.22f, 0.75f };

/* ---- small 4x4 matrix helpers, column-major as GL wants ---- */
static void mat_mul(float *o, const float *a, const float *b)
{
	float t[16];
	for (int c = 0; c < 4; c++)
		for (int r = 0; r < 4; r++) {
			float s = 0;
			for (int k = 0; k < 4; k++)
				s += a[k * 4 + r] * b[c * 4 + k];
			t[c * 4 + r] = s;
		}
	memcpy(o, t, sizeof(t));
}

static void mat_perspective(float *m, float fovy, float aspect, float n, float f)
{
	float t = 1.0f / tanf(fovy / 2);
	memset(m, 0, 16 * sizeof(float));
	m[0] = t / aspect;
	m[5] = t;
	m[10] = (f + n) / (n - f);
	m[11] = -1;
	m[14] = 2 * f * n / (n - f);
}

static void mat_ortho(float *m, float l, float r, float b, float t, float n, float f)
{
	memset(m, 0, 16 * sizeof(float));
	m[0] = 2 / (r - l);
	m[5] = 2 / (t - b);
	m[10] = -2 / (f - n);
	m[12] = -(r + l) / (r - l);
	m[13] = -(t + b) / (t - b);
	m[14] = -(f + n) / (f - n);
	m[15] = 1;
}

static void v3_norm(float *v)
{
	float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
	if (l > 0) {
		v[0] /= l;
		v[1] /= l;
		v[2] /= l;
	}
}

static void v3_cross(float *o, const float *a, const float *b)
{
	float t[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
	memcpy(o, t, sizeof(t));
}

static void mat_lookat(float *m, const float *eye, const float *at, const float *up)
{
	float f[3] = { at[0] - eye[0], at[1] - eye[1], at[2] - eye[2] }, s[3], u[3];
	v3_norm(f);
	v3_cross(s, f, up);
	v3_norm(s);
	v3_cross(u, s, f);
	memset(m, 0, 16 * sizeof(float));
	for (int k = 0; k < 3; k++) { /* the rows: side, up, back */
		m[4 * k] = s[k];
		m[4 * k + 1] = u[k];
		m[4 * k + 2] = -f[k];
	}
	m[12] = -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]);
	m[13] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
	m[14] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
	m[15] = 1;
}

/* ---- shaders ---- */
static const char *const lit_vs =
	"#version 330 core\n"
	"layout(location = 0) in vec3 a_pos;\n"
	"layout(location = 1) in vec3 a_nrm;\n"
	"layout(location = 2) in vec3 a_col;\n"
	"uniform mat4 u_mvp;\n"
	"out vec3 v_pos; out vec3 v_nrm; out vec3 v_col;\n"
	"void main() { v_pos = a_pos; v_nrm = a_nrm; v_col = a_col; gl_Position = u_mvp * vec4(a_pos, 1.0); }\n";

static const char *const lit_fs = "#version 330 core\n"
				  "in vec3 v_pos; in vec3 v_nrm; in vec3 v_col;\n"
				  "uniform vec3 u_light; uniform vec3 u_eye;\n"
				  "out vec4 o_col;\n"
				  "void main() {\n"
				  "  vec3 n = normalize(v_nrm);\n"
				  "  vec3 v = normalize(u_eye - v_pos);\n"
				  "  float d = max(dot(n, u_light), 0.0);\n"
				  "  float s = pow(max(dot(n, normalize(u_light + v)), 0.0), 40.0);\n"
				  "  o_col = vec4(v_col * (0.32 + 0.68 * d) + vec3(0.18 * s), 1.0);\n"
				  "}\n";

static const char *const water_vs = "#version 330 core\n"
				    "layout(location = 0) in vec2 a_uv;\n"
				    "uniform sampler2D u_h;\n"
				    "uniform vec2 u_size;\n" /* pool size, m */
				    "uniform float u_zs;\n" /* m of display per mm of height */
				    "uniform mat4 u_mvp;\n"
				    "out vec2 v_uv; out vec3 v_pos;\n"
				    "void main() {\n"
				    "  float h = textureLod(u_h, a_uv, 0.0).r;\n"
				    "  v_uv = a_uv;\n"
				    "  v_pos = vec3(a_uv * u_size, h * u_zs);\n"
				    "  gl_Position = u_mvp * vec4(v_pos, 1.0);\n"
				    "}\n";

/* Water. Both looks: normals by central differences of the received heights (the grid the mesh
 * samples), a Blinn-Phong sun from light_dir, a sky (horizon pale, zenith blue) reflected by Schlick's
 * Fresnel term. flat: a body colour tinted by height, more opaque at grazing angles. water: what is
 * under the surface is the pool's tiled floor along the refracted ray (index 1.33), dimmed by the
 * water on the sun's way down and the eye's way up (absorption strongest in red), and lit through the
 * curved surface: the Laplacian of the heights focuses or spreads the sun (caustics, to first order in
 * the floor's depth). A millimetre wave tilts the normal by a few degrees; the floor's lines bend and
 * the caustics brighten by tens of percent, which is what makes such waves visible. Around the object
 * a bright meniscus ring and its shadow on the surface, the sun's way. The colour scale replaces the
 * body colour (flat look); the map view is the colour scale with a little hill shading, opaque. */
static const char *const water_fs =
	"#version 330 core\n"
	"in vec2 v_uv; in vec3 v_pos;\n"
	"uniform sampler2D u_h;\n"
	"uniform vec2 u_texel;\n" /* 1/nx, 1/ny */
	"uniform vec2 u_cell;\n" /* 2 dx in m: central differences span two cells */
	"uniform float u_zs;\n"
	"uniform vec3 u_light; uniform vec3 u_eye;\n"
	"uniform int u_colour; uniform int u_map; uniform float u_range;\n"
	"uniform vec3 u_ramp_lo; uniform vec3 u_ramp_mid; uniform vec3 u_ramp_hi;\n"
	"uniform int u_water;\n" /* 1: the water look */
	"uniform float u_depth;\n" /* m, the floor under the rest surface */
	"uniform vec4 u_obj;\n" /* object footprint: centre x, y and half sizes, m (zw 0: none) */
	"uniform vec2 u_obj_z;\n" /* its bottom and top as drawn, m */
	"out vec4 o_col;\n"
	"vec3 pool_floor(vec2 p) {\n" /* 50 mm tiles, two tones, grout lines at 25 mm + k 50 mm */
	"  vec2 g = (p - 0.025) / 0.05, f = abs(fract(g) - 0.5);\n"
	"  float grout = smoothstep(0.472, 0.490, max(f.x, f.y));\n"
	"  vec3 tile = mix(vec3(0.86, 0.86, 0.80), vec3(0.80, 0.84, 0.80), mod(floor(g.x) + floor(g.y), 2.0));\n"
	"  return mix(tile, vec3(0.64, 0.70, 0.70), grout);\n"
	"}\n"
	"float in_box(vec2 p) { vec2 q = abs(p - u_obj.xy) - u_obj.zw; return max(q.x, q.y) < 0.0 ? 1.0 : 0.0; }\n"
	"void main() {\n"
	"  float hc = texture(u_h, v_uv).r;\n"
	"  vec2 ex = vec2(u_texel.x, 0.0), ey = vec2(0.0, u_texel.y);\n"
	"  float hxp = texture(u_h, v_uv + ex).r, hxm = texture(u_h, v_uv - ex).r;\n"
	"  float hyp = texture(u_h, v_uv + ey).r, hym = texture(u_h, v_uv - ey).r;\n"
	"  vec3 n = normalize(vec3(-(hxp - hxm) * u_zs / u_cell.x, -(hyp - hym) * u_zs / u_cell.y, 1.0));\n"
	"  vec3 v = normalize(u_eye - v_pos);\n"
	"  float t = clamp(hc / u_range, -1.0, 1.0);\n"
	"  vec3 ramp = t < 0.0 ? mix(u_ramp_mid, u_ramp_lo, -t) : mix(u_ramp_mid, u_ramp_hi, t);\n"
	"  float d = max(dot(n, u_light), 0.0);\n"
	"  if (u_map != 0) { o_col = vec4(ramp * (0.70 + 0.40 * d), 1.0); return; }\n"
	"  vec3 r = reflect(-v, n);\n"
	"  vec3 sky = mix(vec3(0.70, 0.80, 0.88), vec3(0.22, 0.42, 0.72), clamp(r.z, 0.0, 1.0));\n"
	"  float fr = 0.02 + 0.98 * pow(1.0 - max(dot(n, v), 0.0), 5.0);\n"
	"  float s = pow(max(dot(n, normalize(u_light + v)), 0.0), 250.0);\n"
	"  if (u_water == 0 || u_colour != 0) {\n"
	"    vec3 base = u_colour != 0 ? ramp : mix(vec3(0.03, 0.22, 0.40), vec3(0.16, 0.55, 0.70), 0.5 + 0.5 * t);\n"
	"    vec3 c = mix(base * (0.22 + 0.95 * d), sky, u_colour != 0 ? 0.5 * fr : fr) + vec3(0.50 * s);\n"
	"    o_col = vec4(c, u_colour != 0 ? 0.90 : mix(0.80, 1.0, fr));\n"
	"    return;\n"
	"  }\n"
	"  vec3 rd = refract(-v, n, 0.75);\n"
	"  float path = (v_pos.z + u_depth) / max(-rd.z, 0.25);\n"
	"  float dx = 0.5 * u_cell.x, lap = (hxp + hxm + hyp + hym - 4.0 * hc) * u_zs / (dx * dx);\n"
	"  float caustic = clamp(1.0 - 0.25 * u_depth * lap, 0.3, 2.5);\n"
	"  vec3 absorb = exp(-vec3(16.0, 5.0, 2.5) * (path + u_depth / u_light.z));\n"
	"  vec3 under = pool_floor(v_pos.xy + rd.xy * path) * caustic * absorb;\n"
	"  under += vec3(0.02, 0.17, 0.28) * (1.0 - absorb);\n"
	"  float shade = 1.0, ring = 0.0, inside = 0.0;\n"
	"  if (u_obj.z > 0.0) {\n"
	"    inside = in_box(v_pos.xy);\n"
	"    vec2 sp = v_pos.xy + u_light.xy / u_light.z * max(u_obj_z.y - v_pos.z, 0.0);\n"
	"    shade = 1.0 - 0.40 * in_box(sp) * (1.0 - inside);\n"
	"    float e = length(max(abs(v_pos.xy - u_obj.xy) - u_obj.zw, 0.0));\n"
	"    bool wet = u_obj_z.x < v_pos.z && v_pos.z < u_obj_z.y;\n"
	"    ring = wet ? exp(-e / 0.0015) * (1.0 - inside) : 0.0;\n"
	"  }\n"
	"  vec3 c = mix(under * (0.25 + d) * shade, sky, fr) + vec3(0.60 * s) * shade;\n"
	"  c = mix(c, vec3(0.80, 0.90, 0.98), 0.55 * ring);\n"
	"  o_col = vec4(c, mix(1.0, 0.60, inside));\n"
	"}\n";

static const char *const hud_vs = "#version 330 core\n"
				  "out vec2 v_uv;\n"
				  "void main() {\n"
				  "  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n"
				  "  v_uv = vec2(p.x, 1.0 - p.y);\n" /* the HUD image's first row is the top one */
				  "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
				  "}\n";

static const char *const hud_fs = "#version 330 core\n"
				  "in vec2 v_uv;\n"
				  "uniform sampler2D u_hud;\n"
				  "out vec4 o_col;\n"
				  "void main() { o_col = texture(u_hud, v_uv); }\n";

/* o when it compiled (a shader) or linked (prog: a program); else its log on stderr, o deleted, 0. */
static unsigned checked(GLuint o, bool prog, const char *name)
{
	GLint ok = 0;
	char log[2048] = ""; /* filled by the info log; empty if the driver gives none */

	(prog ? glGetProgramiv : glGetShaderiv)(o, prog ? GL_LINK_STATUS : GL_COMPILE_STATUS, &ok);
	if (ok)
		return o;
	(prog ? glGetProgramInfoLog : glGetShaderInfoLog)(o, sizeof(log), NULL, log);
	fprintf(stderr, "swell-view: %s %s: %s\n", prog ? "program" : "shader", name, log);
	(prog ? glDeleteProgram : glDeleteShader)(o);
	return 0;
}

static unsigned compile(GLenum kind, const char *src, const char *name)
{
	GLuint s = glCreateShader(kind);
	glShaderSource(s, 1, &src, NULL);
	glCompileShader(s);
	return checked(s, false, name);
}

static unsigned program(const char *vs, const char *fs, const char *name)
{
	GLuint v = compile(GL_VERTEX_SHADER, vs, name), f = compile(GL_FRAGMENT_SHADER, fs, name);
	if (!v || !f)
		return 0;
	GLuint p = glCreateProgram();
	glAttachShader(p, v);
	glAttachShader(p, f);
	glLinkProgram(p);
	glDeleteShader(v);
	glDeleteShader(f);
	return checked(p, true, name);
}

/* The bound 2D texture: filter (GL_NEAREST or GL_LINEAR) both ways, clamped to its edges. */
static void tex_params(GLint filter)
{
	glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
	glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
	glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
	glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
}

/* ---- framebuffers ---- */
static void fb_free(struct render *r)
{
	glDeleteFramebuffers(1, &r->fbo_ms);
	glDeleteFramebuffers(1, &r->fbo_res);
	glDeleteRenderbuffers(1, &r->rb_ms_col);
	glDeleteRenderbuffers(1, &r->rb_ms_depth);
	glDeleteRenderbuffers(1, &r->rb_res_col);
	r->fbo_ms = r->fbo_res = r->rb_ms_col = r->rb_ms_depth = r->rb_res_col = 0;
}

static bool fb_make(struct render *r)
{
	GLint max_samples = 0;
	glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
	r->samples = r->o.msaa <= max_samples ? r->o.msaa : max_samples;

	glGenRenderbuffers(1, &r->rb_ms_col);
	glBindRenderbuffer(GL_RENDERBUFFER, r->rb_ms_col);
	glRenderbufferStorageMultisample(GL_RENDERBUFFER, r->samples, GL_RGBA8, r->o.w, r->o.h);
	glGenRenderbuffers(1, &r->rb_ms_depth);
	glBindRenderbuffer(GL_RENDERBUFFER, r->rb_ms_depth);
	glRenderbufferStorageMultisample(GL_RENDERBUFFER, r->samples, GL_DEPTH_COMPONENT24, r->o.w, r->o.h);
	glGenFramebuffers(1, &r->fbo_ms);
	glBindFramebuffer(GL_FRAMEBUFFER, r->fbo_ms);
	glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->rb_ms_col);
	glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->rb_ms_depth);
	if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
		fprintf(stderr, "swell-view: multisampled framebuffer incomplete\n");
		return false;
	}
	glGenRenderbuffers(1, &r->rb_res_col);
	glBindRenderbuffer(GL_RENDERBUFFER, r->rb_res_col);
	glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, r->o.w, r->o.h);
	glGenFramebuffers(1, &r->fbo_res);
	glBindFramebuffer(GL_FRAMEBUFFER, r->fbo_res);
	glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->rb_res_col);
	if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
		fprintf(stderr, "swell-view: resolve framebuffer incomplete\n");
		return false;
	}
	glBindFramebuffer(GL_FRAMEBUFFER, 0);

	canvas_free(&r->hud);
	r->hud_ntext = -1; /* new size: rebuild the HUD */
	if (!canvas_init(&r->hud, r->o.w, r->o.h, r->o.h >= 700 ? 2 : 1))
		return false;
	glBindTexture(GL_TEXTURE_2D, r->tex_hud);
	glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, r->o.w, r->o.h, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
	return true;
}

bool render_resize(struct render *r, int w, int h)
{
	if (w < 16 || h < 16 || (w == r->o.w && h == r->o.h))
		return true;
	fb_free(r);
	r->o.w = w;
	r->o.h = h;
	return fb_make(r);
}

bool render_init(struct render *r, const struct render_opts *o)
{
	memset(r, 0, sizeof(*r));
	r->o = *o;
	const char *gl = (const char *)glGetString(GL_RENDERER);
	if (r->o.msaa < 0) /* not chosen: 4 on a GPU, none on a software renderer (it costs 2.4x there) */
		r->o.msaa = gl && (strstr(gl, "llvmpipe") || strstr(gl, "softpipe")) ? 0 : 4;
	r->prog_lit = program(lit_vs, lit_fs, "lit");
	r->prog_water = program(water_vs, water_fs, "water");
	r->prog_hud = program(hud_vs, hud_fs, "hud");
	if (!r->prog_lit || !r->prog_water || !r->prog_hud)
		return false;

	glGenVertexArrays(1, &r->vao_water);
	glGenBuffers(1, &r->vbo_water);
	glGenBuffers(1, &r->ibo_water);
	glGenVertexArrays(1, &r->vao_lit);
	glGenBuffers(1, &r->vbo_lit);
	glBindVertexArray(r->vao_lit);
	glBindBuffer(GL_ARRAY_BUFFER, r->vbo_lit);
	for (GLuint k = 0; k < 3; k++) {
		glEnableVertexAttribArray(k);
		glVertexAttribPointer(k, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float), (void *)(k * 3 * sizeof(float)));
	}
	glGenVertexArrays(1, &r->vao_hud);
	glBindVertexArray(0);

	glGenTextures(1, &r->tex_h);
	glGenTextures(1, &r->tex_hud);
	glBindTexture(GL_TEXTURE_2D, r->tex_hud);
	tex_params(GL_NEAREST);

	if (!fb_make(r))
		return false;
	GLenum e = glGetError();
	if (e != GL_NO_ERROR) {
		fprintf(stderr, "swell-view: GL error 0x%04x during set-up\n", e);
		return false;
	}
	return true;
}

void render_free(struct render *r)
{
	fb_free(r);
	glDeleteProgram(r->prog_lit);
	glDeleteProgram(r->prog_water);
	glDeleteProgram(r->prog_hud);
	glDeleteVertexArrays(1, &r->vao_water);
	glDeleteVertexArrays(1, &r->vao_lit);
	glDeleteVertexArrays(1, &r->vao_hud);
	glDeleteBuffers(1, &r->vbo_water);
	glDeleteBuffers(1, &r->ibo_water);
	glDeleteBuffers(1, &r->vbo_lit);
	glDeleteTextures(1, &r->tex_h);
	glDeleteTextures(1, &r->tex_hud);
	for (int k = 0; k < RENDER_OVERLAYS; k++)
		glDeleteTextures(1, &r->ov[k].tex);
	free(r->lit);
	canvas_free(&r->hud);
	memset(r, 0, sizeof(*r));
}

/* ---- the water mesh and height texture, rebuilt when the scene changes ---- */
#define WATER_MESH_MAX 128 /* quads a side at most: the vertex work of a 256 x 256 pool is a quarter */

static bool water_make(struct render *r, int nx_cells, int ny_cells)
{
	/* (nx+1) x (ny+1) corner vertices: the surface reaches the walls; a corner samples the
	 * bilinear mean of the cells around it (clamped at the walls, as the solver's mirror). Pools
	 * bigger than WATER_MESH_MAX cells a side get a coarser mesh; their normals and colours still
	 * come from every cell (the fragment shader reads the full texture). */
	int nx = nx_cells < WATER_MESH_MAX ? nx_cells : WATER_MESH_MAX;
	int ny = ny_cells < WATER_MESH_MAX ? ny_cells : WATER_MESH_MAX;
	size_t nv = (size_t)(nx + 1) * (size_t)(ny + 1), ni = (size_t)nx * (size_t)ny * 6;
	float *uv = malloc(nv * 2 * sizeof(float));
	unsigned *idx = malloc(ni * sizeof(unsigned));
	if (!uv || !idx) {
		free(uv);
		free(idx);
		return false;
	}
	for (int j = 0; j <= ny; j++)
		for (int i = 0; i <= nx; i++) {
			uv[((size_t)j * (nx + 1) + i) * 2] = (float)i / (float)nx;
			uv[((size_t)j * (nx + 1) + i) * 2 + 1] = (float)j / (float)ny;
		}
	size_t k = 0;
	for (int j = 0; j < ny; j++)
		for (int i = 0; i < nx; i++) {
			unsigned a = (unsigned)(j * (nx + 1) + i), b = a + 1, c = a + (unsigned)nx + 1, d = c + 1;
			const unsigned two[6] = { a, b, d, a, d, c }; /* two triangles */
			memcpy(idx + k, two, sizeof(two));
			k += 6;
		}
	glBindVertexArray(r->vao_water);
	glBindBuffer(GL_ARRAY_BUFFER, r->vbo_water);
	glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(nv * 2 * sizeof(float)), uv, GL_STATIC_DRAW);
	glEnableVertexAttribArray(0);
	glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 2 * sizeof(float), (void *)0);
	glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ibo_water);
	glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(ni * sizeof(unsigned)), idx, GL_STATIC_DRAW);
	glBindVertexArray(0);
	free(uv);
	free(idx);

	glBindTexture(GL_TEXTURE_2D, r->tex_h);
	glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, nx_cells, ny_cells, 0, GL_RED, GL_FLOAT, NULL);
	tex_params(GL_LINEAR);
	r->water_nx = nx_cells;
	r->water_ny = ny_cells;
	r->water_indices = (int)ni;
	return true;
}

static void upload_tiles(struct render *r, struct view_model *m)
{
	r->tiles_uploaded_last = 0;
	if (m->dirty_count == 0)
		return;
	glBindTexture(GL_TEXTURE_2D, r->tex_h);
	glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
	glPixelStorei(GL_UNPACK_ROW_LENGTH, m->scene.nx);
	for (uint16_t ty = 0; ty < m->tiles_y; ty++)
		for (uint16_t tx = 0; tx < m->tiles_x; tx++) {
			if (!vm_tile_dirty(m, tx, ty))
				continue;
			uint16_t i0, j0, w, h;
			vm_tile_rect(m, tx, ty, &i0, &j0, &w, &h);
			glTexSubImage2D(GL_TEXTURE_2D, 0, i0, j0, w, h, GL_RED, GL_FLOAT,
					m->h_mm + (size_t)j0 * m->scene.nx + i0);
			vm_tile_clean(m, tx, ty);
			r->tiles_uploaded_last++;
			r->texels_uploaded += (uint64_t)w * h;
		}
	glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
	r->tiles_uploaded += r->tiles_uploaded_last;
}

/* ---- lit geometry, rebuilt every frame (a few hundred vertices) ---- */
static void lit_vertex(struct render *r, const float *p, const float *n, const float *c)
{
	if (r->lit_n == r->lit_cap) {
		int cap = r->lit_cap ? r->lit_cap * 2 : 1024;
		float *nl = realloc(r->lit, (size_t)cap * 9 * sizeof(float));
		if (!nl)
			return;
		r->lit = nl;
		r->lit_cap = cap;
	}
	float *v = r->lit + (size_t)r->lit_n * 9;
	memcpy(v, p, 3 * sizeof(float));
	memcpy(v + 3, n, 3 * sizeof(float));
	memcpy(v + 6, c, 3 * sizeof(float));
	r->lit_n++;
}

static void lit_tri(struct render *r, const float *a, const float *b, const float *c, const float *col)
{
	float e1[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, e2[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] },
	      n[3];
	v3_cross(n, e1, e2);
	v3_norm(n);
	lit_vertex(r, a, n, col);
	lit_vertex(r, b, n, col);
	lit_vertex(r, c, n, col);
}

static void lit_quad(struct render *r, const float *a, const float *b, const float *c, const float *d, const float *col)
{
	lit_tri(r, a, b, c, col);
	lit_tri(r, a, c, d, col);
}

/* A hexahedron from 8 corners: 0-3 the bottom ring, 4-7 the top ring, both counter-clockwise seen
 * from above (+z of the shape's own frame). Faces wind outwards. */
static void lit_hex(struct render *r, float p[8][3], const float *col)
{
	lit_quad(r, p[3], p[2], p[1], p[0], col); /* bottom */
	lit_quad(r, p[4], p[5], p[6], p[7], col); /* top */
	for (int k = 0; k < 4; k++) {
		int k1 = (k + 1) % 4;
		lit_quad(r, p[k], p[k1], p[k1 + 4], p[k + 4], col);
	}
}

static void lit_box(struct render *r, float x0, float y0, float z0, float x1, float y1, float z1, const float *col)
{
	float p[8][3] = { { x0, y0, z0 }, { x1, y0, z0 }, { x1, y1, z0 }, { x0, y1, z0 },
			  { x0, y0, z1 }, { x1, y0, z1 }, { x1, y1, z1 }, { x0, y1, z1 } };
	lit_hex(r, p, col);
}

/* An arrow from `o` along `d` (length len, m): square shaft and a four-sided head. */
static void lit_arrow(struct render *r, const float *o, const float *dir, float len, float width, const float *col)
{
	float d[3] = { dir[0], dir[1], dir[2] }, u[3], v[3], ref[3] = { 0, 0, 1 };
	v3_norm(d);
	if (fabsf(d[2]) > 0.9f) {
		ref[0] = 1;
		ref[2] = 0;
	}
	v3_cross(u, d, ref);
	v3_norm(u);
	v3_cross(v, u, d);
	float head = fminf(len * 0.45f, width * 4.5f), shaft = len - head, hw = width / 2, hh = width * 1.6f;
	/* three rings of four corners: the shaft's bottom and top, the head's base */
	float p[12][3], (*b)[3] = p + 8, tip[3];
	for (int k = 0; k < 12; k++) {
		float half = k < 8 ? hw : hh, t = k >= 4 ? shaft : 0;
		float su = (k % 4 == 1 || k % 4 == 2) ? half : -half, sv = (k % 4 >= 2) ? half : -half;
		for (int a = 0; a < 3; a++)
			p[k][a] = o[a] + d[a] * t + u[a] * su + v[a] * sv;
	}
	lit_hex(r, p, col);
	for (int a = 0; a < 3; a++)
		tip[a] = o[a] + d[a] * len;
	lit_quad(r, b[3], b[2], b[1], b[0], col);
	for (int k = 0; k < 4; k++)
		lit_tri(r, b[k], b[(k + 1) % 4], tip, col);
}

/* Water height in mm at pool point (x, y) m, bilinear between cell centres as the texture does. */
static float height_at(const struct view_model *m, float x, float y)
{
	float dx = (float)m->scene.dx_um * 1e-6f;
	float fi = x / dx - 0.5f, fj = y / dx - 0.5f;
	int nx = m->scene.nx, ny = m->scene.ny;
	fi = fminf(fmaxf(fi, 0), (float)(nx - 1));
	fj = fminf(fmaxf(fj, 0), (float)(ny - 1));
	int i = (int)fi, j = (int)fj;
	int i1 = i + 1 < nx ? i + 1 : i, j1 = j + 1 < ny ? j + 1 : j;
	float a = fi - (float)i, b = fj - (float)j;
	const float *h = m->h_mm;
	return (1 - b) * ((1 - a) * h[j * nx + i] + a * h[j * nx + i1]) +
		b * ((1 - a) * h[j1 * nx + i] + a * h[j1 * nx + i1]);
}

static void build_scene(struct render *r, const struct view_model *m, bool frozen)
{
	static const float wall_col[3] = { 0.78f, 0.80f, 0.83f }, floor_col[3] = { 0.78f, 0.76f, 0.66f };
	static const float obj_col[3] = { 1.00f, 0.58f, 0.10f }, arrow_col[3] = { 0.92f, 0.10f, 0.30f };
	float dx = (float)m->scene.dx_um * 1e-6f, depth = (float)m->scene.depth_um * 1e-6f;
	float lx = dx * (float)m->scene.nx, ly = dx * (float)m->scene.ny;
	float t = 0.03f * fmaxf(lx, ly), rim = 0.35f * depth + 0.004f;

	r->lit_n = 0;
	lit_box(r, -t, -t, -depth - t, lx + t, ly + t, -depth, floor_col);
	lit_box(r, -t, -t, -depth, 0, ly + t, rim, wall_col);
	lit_box(r, lx, -t, -depth, lx + t, ly + t, rim, wall_col);
	lit_box(r, 0, -t, -depth, lx, 0, rim, wall_col);
	lit_box(r, 0, ly, -depth, lx, ly + t, rim, wall_col);

	r->obj_box[2] = 0; /* no object: no ring, no shadow */
	if (!m->obj.valid)
		return;
	float ox = (float)m->obj.x_um * 1e-6f, oy = (float)m->obj.y_um * 1e-6f;
	float a = (float)m->obj.a_um * 1e-6f, b = (float)m->obj.b_um * 1e-6f, hgt = (float)m->obj.h_um * 1e-6f;
	/* The water is drawn zscale times higher; the object rides it the same way, keeping its true
	 * submersion: its bottom moves with (zscale - 1) x the water height under it. */
	if (!frozen)
		r->obj_water_mm = height_at(m, ox, oy);
	float w = r->obj_water_mm * 1e-3f;
	float z0 = (float)m->obj.z_um * 1e-6f + (r->o.zscale - 1.0f) * w;
	if (r->o.view == RENDER_MAP) {
		/* the footprint outlined in black above everything, so the heights under it stay readable */
		static const float outline_col[3] = { 0.02f, 0.02f, 0.02f };
		float e = fmaxf(0.0015f, 0.004f * fmaxf(lx, ly)), zt = 0.2f * fmaxf(lx, ly);
		lit_box(r, ox - a / 2 - e, oy - b / 2 - e, zt, ox + a / 2 + e, oy - b / 2, zt + e, outline_col);
		lit_box(r, ox - a / 2 - e, oy + b / 2, zt, ox + a / 2 + e, oy + b / 2 + e, zt + e, outline_col);
		lit_box(r, ox - a / 2 - e, oy - b / 2, zt, ox - a / 2, oy + b / 2, zt + e, outline_col);
		lit_box(r, ox + a / 2, oy - b / 2, zt, ox + a / 2 + e, oy + b / 2, zt + e, outline_col);
		z0 = zt - hgt; /* the force arrow starts at the outline's height */
	} else {
		lit_box(r, ox - a / 2, oy - b / 2, z0, ox + a / 2, oy + b / 2, z0 + hgt, obj_col);
		const float box[4] = { ox, oy, a / 2, b / 2 };
		memcpy(r->obj_box, box, sizeof(box));
		r->obj_z[0] = z0;
		r->obj_z[1] = z0 + hgt;
	}

	float f[3] = { (float)m->obj.fx_cN * 0.01f, (float)m->obj.fy_cN * 0.01f, (float)m->obj.fz_cN * 0.01f };
	float fn = sqrtf(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
	float len = fn * r->o.force_mm_per_N * 1e-3f, maxlen = 0.6f * fmaxf(lx, ly);
	if (len > maxlen)
		len = maxlen;
	if (len > 0.004f) {
		float o[3] = { ox, oy, z0 + hgt };
		lit_arrow(r, o, f, len, fmaxf(0.004f, 0.012f * fmaxf(lx, ly)), arrow_col);
	}
}

/* ---- camera ---- */
static void scene_size(const struct view_model *m, float *lx, float *ly, float *depth)
{
	float dx = m->have_scene ? (float)m->scene.dx_um * 1e-6f : (float)SWELL_POOL_DX_UM / 1e6f;
	*lx = dx * (float)(m->have_scene ? m->scene.nx : 64);
	*ly = dx * (float)(m->have_scene ? m->scene.ny : 64);
	*depth = m->have_scene ? (float)m->scene.depth_um * 1e-6f : 0.05f;
}

void render_cam_reset(struct render *r, const struct view_model *m)
{
	float lx, ly, depth;
	scene_size(m, &lx, &ly, &depth);
	r->cam.yaw = -PI_F / 2 - 0.45f;
	r->cam.pitch = 0.72f;
	r->cam.dist = 1.9f * fmaxf(lx, ly);
	r->cam.pan_x = r->cam.pan_y = 0;
	r->cam_set = true;
}

void render_cam_orbit(struct render *r, float dyaw, float dpitch)
{
	r->cam.yaw += dyaw;
	r->cam.pitch = fminf(fmaxf(r->cam.pitch + dpitch, 0.05f), 1.55f);
}

void render_cam_zoom(struct render *r, float factor)
{
	r->cam.dist = fminf(fmaxf(r->cam.dist * factor, 0.05f), 20.0f);
}

static void camera(struct render *r, const struct view_model *m, float *mvp, float *eye)
{
	float lx, ly, depth, view[16], proj[16];
	scene_size(m, &lx, &ly, &depth);
	int sw = r->o.w - r->scene_right; /* the scene's part of the framebuffer */
	float aspect = (float)sw / (float)r->o.h;
	if (r->o.view != RENDER_ORBIT) {
		/* Pool centred and fitted with a 5 % margin: pixel = centre + (x - Lx/2) * s. */
		float s = 0.9f * fminf((float)sw / lx, (float)r->o.h / ly);
		float hw = (float)sw / (2 * s), hh = (float)r->o.h / (2 * s);
		float e[3] = { lx / 2, ly / 2, 5 }, at[3] = { lx / 2, ly / 2, 0 }, up[3] = { 0, 1, 0 };
		mat_lookat(view, e, at, up);
		memcpy(eye, e, sizeof(e)); /* the eye for lighting: straight above */
		mat_ortho(proj, -hw, hw, -hh, hh, 0.1f, 20);
	} else {
		if (!r->cam_set)
			render_cam_reset(r, m);
		float at[3] = { lx / 2 + r->cam.pan_x, ly / 2 + r->cam.pan_y, -depth / 3 }, up[3] = { 0, 0, 1 };
		/* a view narrower than 4:3 (the charts take the right) steps back to keep the pool in it */
		float dist = r->cam.dist * fmaxf(1.0f, (4.0f / 3.0f) / aspect);
		eye[0] = at[0] + dist * cosf(r->cam.pitch) * cosf(r->cam.yaw);
		eye[1] = at[1] + dist * cosf(r->cam.pitch) * sinf(r->cam.yaw);
		eye[2] = at[2] + dist * sinf(r->cam.pitch);
		mat_lookat(view, eye, at, up);
		mat_perspective(proj, 0.70f, aspect, dist * 0.05f, dist * 10);
	}
	mat_mul(mvp, proj, view);
}

/* ---- HUD ---- */
void render_text_clear(struct render *r)
{
	r->ntext = 0;
}

void render_text_add(struct render *r, int x, int y, uint8_t cr, uint8_t cg, uint8_t cb, bool panel, const char *s)
{
	if (r->ntext >= RENDER_HUD_ITEMS)
		return;
	struct render_text *t = &r->text[r->ntext++];
	*t = (struct render_text){ .x = x, .y = y, .r = cr, .g = cg, .b = cb, .panel = panel };
	snprintf(t->s, sizeof(t->s), "%s", s);
}

static void build_hud(struct render *r)
{
	static const uint8_t panel[4] = { 8, 8, 8, 165 };
	struct canvas *c = &r->hud;
	int pad = 4 * c->scale;

	canvas_clear(c);
	for (int k = 0; k < r->ntext; k++) {
		const struct render_text *t = &r->text[k];
		int tw, th;
		canvas_text_size(c, t->s, &tw, &th);
		int x = t->x < 0 ? c->w + t->x * c->scale - tw : t->x * c->scale;
		int y = t->y < 0 ? c->h + t->y * c->scale - th : t->y * c->scale;
		const uint8_t rgb[3] = { t->r, t->g, t->b };
		if (t->panel)
			canvas_fill(c, x - pad, y - pad, tw + 2 * pad - c->scale, th + 2 * pad - 2 * c->scale, panel);
		canvas_text(c, x, y, rgb, t->s);
	}
	glBindTexture(GL_TEXTURE_2D, r->tex_hud);
	glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
	glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, c->w, c->h, GL_RGBA, GL_UNSIGNED_BYTE, c->rgba);
	glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
}

/* ---- overlays: the HUD's full-screen triangle drawn into the overlay's rectangle ---- */
void render_overlay(struct render *r, int slot, const uint8_t *rgba, int w, int h, int x, int y)
{
	if (slot < 0 || slot >= RENDER_OVERLAYS || w < 1 || h < 1)
		return;
	struct render_overlay *o = &r->ov[slot];
	if (!o->tex) {
		glGenTextures(1, &o->tex);
		glBindTexture(GL_TEXTURE_2D, o->tex);
		tex_params(GL_NEAREST);
	}
	glBindTexture(GL_TEXTURE_2D, o->tex);
	glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
	if (o->tex_w != w || o->tex_h != h) {
		glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
		o->tex_w = w;
		o->tex_h = h;
	} else {
		glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
	}
	glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
	o->on = true;
	o->x = x;
	o->y = y;
	o->w = w;
	o->h = h;
}

void render_overlay_off(struct render *r, int slot)
{
	if (slot >= 0 && slot < RENDER_OVERLAYS)
		r->ov[slot].on = false;
}

/* Blended, no depth: the HUD's program and full-screen triangle, texture unit 0. */
static void hud_begin(struct render *r)
{
	glDisable(GL_DEPTH_TEST);
	glDisable(GL_CULL_FACE);
	glEnable(GL_BLEND);
	glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
	glUseProgram(r->prog_hud);
	glActiveTexture(GL_TEXTURE0);
	glUniform1i(glGetUniformLocation(r->prog_hud, "u_hud"), 0);
	glBindVertexArray(r->vao_hud);
}

static void draw_overlays(struct render *r)
{
	hud_begin(r);
	for (int k = 0; k < RENDER_OVERLAYS; k++) {
		const struct render_overlay *o = &r->ov[k];
		if (!o->on)
			continue;
		glBindTexture(GL_TEXTURE_2D, o->tex);
		glViewport(o->x, r->o.h - o->y - o->h, o->w, o->h); /* GL's rows count from the bottom */
		glDrawArrays(GL_TRIANGLES, 0, 3);
	}
	glViewport(0, 0, r->o.w, r->o.h);
}

/* ---- a frame ---- */
void render_frame(struct render *r, struct view_model *m, bool frozen)
{
	float mvp[16], eye[3], light[3] = { light_dir[0], light_dir[1], light_dir[2] };
	v3_norm(light);

	if (m->have_scene && (r->water_nx != m->scene.nx || r->water_ny != m->scene.ny)) {
		if (!water_make(r, m->scene.nx, m->scene.ny))
			return;
		r->cam_set = false; /* a new pool: frame it */
	}
	if (m->have_scene && !frozen)
		upload_tiles(r, m);

	glBindFramebuffer(GL_FRAMEBUFFER, r->fbo_ms);
	glViewport(0, 0, r->o.w, r->o.h);
	glClearColor(0.07f, 0.08f, 0.10f, 1.0f);
	glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

	if (m->have_scene) {
		glViewport(0, 0, r->o.w - r->scene_right, r->o.h);
		camera(r, m, mvp, eye);
		glEnable(GL_DEPTH_TEST);
		glEnable(GL_CULL_FACE);
		glDisable(GL_BLEND);

		build_scene(r, m, frozen);
		glUseProgram(r->prog_lit);
		glUniformMatrix4fv(glGetUniformLocation(r->prog_lit, "u_mvp"), 1, GL_FALSE, mvp);
		glUniform3fv(glGetUniformLocation(r->prog_lit, "u_light"), 1, light);
		glUniform3fv(glGetUniformLocation(r->prog_lit, "u_eye"), 1, eye);
		glBindVertexArray(r->vao_lit);
		glBindBuffer(GL_ARRAY_BUFFER, r->vbo_lit);
		glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)((size_t)r->lit_n * 9 * sizeof(float)), r->lit,
			     GL_STREAM_DRAW);
		glDrawArrays(GL_TRIANGLES, 0, r->lit_n);

		/* water last, translucent, both sides (seen from below through the glass is fine) */
		float dx = (float)m->scene.dx_um * 1e-6f;
		float size[2] = { dx * (float)m->scene.nx, dx * (float)m->scene.ny };
		glDisable(GL_CULL_FACE);
		glEnable(GL_BLEND);
		glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
		glUseProgram(r->prog_water);
		glActiveTexture(GL_TEXTURE0);
		glBindTexture(GL_TEXTURE_2D, r->tex_h);
		glUniform1i(glGetUniformLocation(r->prog_water, "u_h"), 0);
		glUniformMatrix4fv(glGetUniformLocation(r->prog_water, "u_mvp"), 1, GL_FALSE, mvp);
		glUniform2fv(glGetUniformLocation(r->prog_water, "u_size"), 1, size);
		glUniform1f(glGetUniformLocation(r->prog_water, "u_zs"), r->o.zscale * 1e-3f);
		glUniform2f(glGetUniformLocation(r->prog_water, "u_texel"), 1.0f / (float)m->scene.nx,
			    1.0f / (float)m->scene.ny);
		glUniform2f(glGetUniformLocation(r->prog_water, "u_cell"), 2 * dx, 2 * dx);
		glUniform3fv(glGetUniformLocation(r->prog_water, "u_light"), 1, light);
		glUniform3fv(glGetUniformLocation(r->prog_water, "u_eye"), 1, eye);
		glUniform1i(glGetUniformLocation(r->prog_water, "u_colour"), r->o.colour_scale);
		glUniform1i(glGetUniformLocation(r->prog_water, "u_map"), r->o.view == RENDER_MAP);
		glUniform3fv(glGetUniformLocation(r->prog_water, "u_ramp_lo"), 1, canvas_ramp_low);
		glUniform3fv(glGetUniformLocation(r->prog_water, "u_ramp_mid"), 1, canvas_ramp_mid);
		glUniform3fv(glGetUniformLocation(r->prog_water, "u_ramp_hi"), 1, canvas_ramp_high);
		glUniform1f(glGetUniformLocation(r->prog_water, "u_range"), r->o.h_range_mm);
		glUniform1i(glGetUniformLocation(r->prog_water, "u_water"), r->o.shading == RENDER_SHADE_WATER);
		glUniform1f(glGetUniformLocation(r->prog_water, "u_depth"), (float)m->scene.depth_um * 1e-6f);
		glUniform4fv(glGetUniformLocation(r->prog_water, "u_obj"), 1, r->obj_box);
		glUniform2fv(glGetUniformLocation(r->prog_water, "u_obj_z"), 1, r->obj_z);
		glBindVertexArray(r->vao_water);
		glDrawElements(GL_TRIANGLES, r->water_indices, GL_UNSIGNED_INT, (void *)0);
		glViewport(0, 0, r->o.w, r->o.h);
	}

	if (r->o.hud && r->ntext > 0) {
		/* rasterise and upload the HUD only when its text changed (rates change once a second) */
		if (r->ntext != r->hud_ntext ||
		    memcmp(r->text, r->hud_text, sizeof(r->text[0]) * (size_t)r->ntext) != 0) {
			build_hud(r);
			memcpy(r->hud_text, r->text, sizeof(r->text));
			r->hud_ntext = r->ntext;
		}
		hud_begin(r);
		glBindTexture(GL_TEXTURE_2D, r->tex_hud);
		glDrawArrays(GL_TRIANGLES, 0, 3);
	}
	draw_overlays(r);
	glBindVertexArray(0);
	glUseProgram(0);

	glBindFramebuffer(GL_READ_FRAMEBUFFER, r->fbo_ms);
	glBindFramebuffer(GL_DRAW_FRAMEBUFFER, r->fbo_res);
	glBlitFramebuffer(0, 0, r->o.w, r->o.h, 0, 0, r->o.w, r->o.h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
	glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void render_finish(struct render *r)
{
	(void)r;
	glFinish();
}

void render_blit(struct render *r, int win_w, int win_h)
{
	glBindFramebuffer(GL_READ_FRAMEBUFFER, r->fbo_res);
	glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
	glBlitFramebuffer(0, 0, r->o.w, r->o.h, 0, 0, win_w, win_h, GL_COLOR_BUFFER_BIT, GL_LINEAR);
	glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void render_read(struct render *r, uint8_t *rgb)
{
	size_t row = (size_t)r->o.w * 3;
	glBindFramebuffer(GL_READ_FRAMEBUFFER, r->fbo_res);
	glPixelStorei(GL_PACK_ALIGNMENT, 1);
	glReadPixels(0, 0, r->o.w, r->o.h, GL_RGB, GL_UNSIGNED_BYTE, rgb);
	glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
	/* GL's first row is the bottom one */
	uint8_t *tmp = malloc(row);
	if (!tmp)
		return;
	for (int y = 0; y < r->o.h / 2; y++) {
		uint8_t *a = rgb + (size_t)y * row, *b = rgb + (size_t)(r->o.h - 1 - y) * row;
		memcpy(tmp, a, row);
		memcpy(a, b, row);
		memcpy(b, tmp, row);
	}
	free(tmp);
}
