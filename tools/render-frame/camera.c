/* camera.c — view and projection matrices (camera.h). */
#include "camera.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define DEG (M_PI / 180.0)

void rf_camera_defaults(rf_camera *c)
{
	*c = (rf_camera){
		.azimuth = 30, .elevation = 20, .distance = 0, .fov = 30, .margin = 1.1,
		.up = {0, 0, 1}, .light_azimuth = -30, .light_elevation = 30, .cull = 1,
	};
}

void rf_bounds(const float *p, size_t n, size_t stride, double center[3], double *radius)
{
	double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
	for (size_t k = 0; k < n; k++)
		for (int c = 0; c < 3; c++) {
			double v = p[k * stride + c];
			lo[c] = v < lo[c] ? v : lo[c];
			hi[c] = v > hi[c] ? v : hi[c];
		}
	for (int c = 0; c < 3; c++)
		center[c] = n ? 0.5 * (lo[c] + hi[c]) : 0;
	double r2 = 0;
	for (size_t k = 0; k < n; k++) {
		double d2 = 0;
		for (int c = 0; c < 3; c++) {
			double d = p[k * stride + c] - center[c];
			d2 += d * d;
		}
		r2 = d2 > r2 ? d2 : r2;
	}
	*radius = sqrt(r2);
}

static double dot(const double a[3], const double b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross(const double a[3], const double b[3], double out[3])
{
	out[0] = a[1] * b[2] - a[2] * b[1];
	out[1] = a[2] * b[0] - a[0] * b[2];
	out[2] = a[0] * b[1] - a[1] * b[0];
}

static int normalize(double v[3])
{
	double l = sqrt(dot(v, v));
	if (!(l > 0))
		return 0;
	for (int c = 0; c < 3; c++)
		v[c] /= l;
	return 1;
}

void rf_camera_view(const rf_camera *c, const double center[3], double radius, double aspect,
                    rf_view *out)
{
	if (!(radius > 0))
		radius = 1; /* a single point: any scale shows it */
	double half_y = 0.5 * c->fov * DEG;
	double half_x = atan(tan(half_y) * aspect);
	double half = half_x < half_y ? half_x : half_y;
	double target[3], eye[3];
	for (int k = 0; k < 3; k++)
		target[k] = c->have_center ? c->center[k] : center[k];
	double up[3] = {c->up[0], c->up[1], c->up[2]};
	if (!normalize(up))
		up[2] = 1;
	if (c->have_eye) {
		for (int k = 0; k < 3; k++)
			eye[k] = c->eye[k];
	} else {
		/* Azimuth and elevation in the frame of `up`: e1, e2 span the
		 * horizontal plane (for up = +z, e1 = +x and e2 = +y). */
		double e1[3] = {1, 0, 0}, e2[3];
		if (fabs(dot(e1, up)) > 0.9)
			e1[0] = 0, e1[1] = 1;
		double s = dot(e1, up);
		for (int k = 0; k < 3; k++)
			e1[k] -= s * up[k];
		normalize(e1);
		cross(up, e1, e2);
		double d = c->distance > 0 ? c->distance : c->margin * radius / sin(half);
		double az = c->azimuth * DEG, el = c->elevation * DEG;
		for (int k = 0; k < 3; k++)
			eye[k] = target[k] + d * (cos(el) * (cos(az) * e1[k] + sin(az) * e2[k]) +
			                          sin(el) * up[k]);
	}
	/* Look-at: forward f, right s, true up u. */
	double f[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
	if (!normalize(f))
		f[0] = 0, f[1] = 0, f[2] = -1;
	double s[3], u[3];
	cross(f, up, s);
	if (!normalize(s)) { /* looking along up: any right will do */
		double alt[3] = {up[1], up[2], up[0]};
		cross(f, alt, s);
		normalize(s);
	}
	cross(s, f, u);
	float *m = out->modelview;
	for (int k = 0; k < 3; k++) {
		m[4 * k + 0] = (float)s[k];
		m[4 * k + 1] = (float)u[k];
		m[4 * k + 2] = (float)-f[k];
		m[4 * k + 3] = 0;
	}
	m[12] = (float)-dot(s, eye);
	m[13] = (float)-dot(u, eye);
	m[14] = (float)dot(f, eye);
	m[15] = 1;

	/* Near and far planes around the object's bounding sphere. */
	double to_center[3] = {center[0] - eye[0], center[1] - eye[1], center[2] - eye[2]};
	double dist = sqrt(dot(to_center, to_center));
	double zfar = dist + 1.01 * radius;
	double znear = dist - 1.01 * radius;
	if (znear < 1e-3 * zfar)
		znear = 1e-3 * zfar;
	/* Outside a closed surface's bounding sphere only back faces are
	 * hidden behind front ones: skipping them halves the rasterizing. */
	out->cull = c->cull && dist > 1.01 * radius;
	double fy = 1.0 / tan(half_y), fx = fy / aspect;
	float *p = out->projection;
	for (int k = 0; k < 16; k++)
		p[k] = 0;
	p[0] = (float)fx;
	p[5] = (float)fy;
	p[10] = (float)((zfar + znear) / (znear - zfar));
	p[11] = -1;
	p[14] = (float)(2 * zfar * znear / (znear - zfar));

	double la = c->light_azimuth * DEG, le = c->light_elevation * DEG;
	out->light[0] = (float)(cos(le) * sin(la));
	out->light[1] = (float)sin(le);
	out->light[2] = (float)(cos(le) * cos(la));
}

/* Whether the history's first line, split at its blanks (an argument
 * with blanks is quoted, ndo_grid_add_history), is remesh — run under
 * any path — of a mesh, not of a shape (-s, -sNAME, --shape, --shape=). */
static int remeshed_from_mesh(const char *history)
{
	const char *end = strchr(history, '\n');
	size_t len = end ? (size_t)(end - history) : strlen(history);
	const char *p = history, *stop = history + len;
	if (len == 0)
		return 0;
	for (int k = 0; p < stop; k++) {
		const char *t = p;
		while (p < stop && *p != ' ')
			p++;
		size_t n = (size_t)(p - t);
		if (p < stop)
			p++;
		if (k == 0) {
			/* the program: its name after the last '/', quotes aside */
			if (n && t[n - 1] == '\'')
				n--;
			const char *name = t;
			for (const char *q = t; q < t + n; q++)
				if (*q == '/' || *q == '\'')
					name = q + 1;
			if ((size_t)(t + n - name) != 6 || strncmp(name, "remesh", 6) != 0)
				return 0;
		} else if ((n >= 2 && strncmp(t, "-s", 2) == 0) ||
		           (n >= 7 && strncmp(t, "--shape", 7) == 0)) {
			return 0;
		}
	}
	return 1;
}

int rf_camera_for_grid(rf_camera *c, const char *history)
{
	if (c->have_up || !history || !remeshed_from_mesh(history))
		return 0;
	c->up[0] = 0, c->up[1] = 1, c->up[2] = 0;
	if (!c->have_azimuth)
		c->azimuth = 240;
	return 1;
}
