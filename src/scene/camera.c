#include "horizon/camera.h"

#include <math.h>

typedef struct cam_params {
    float fov, aspect, znear, zfar;
} cam_params;

static cam_params params_of(const hz_camera *c)
{
    cam_params p;
    p.fov = glm_rad(c->fov_y > 0 ? c->fov_y : 60.0f);
    p.aspect = c->aspect > 0 ? c->aspect : 16.0f / 9.0f;
    p.znear = c->znear > 0 ? c->znear : 1.0f;
    p.zfar = c->zfar > 0 ? c->zfar : 100000.0f;
    if (p.zfar <= p.znear)
        p.zfar = p.znear * 2.0f;
    return p;
}

void hz_camera_forward(const hz_camera *c, vec3 dest)
{
    float pitch = glm_clamp(c->pitch, -89.9f, 89.9f);
    float y = glm_rad(c->yaw), p = glm_rad(pitch);
    /* yaw 0 -> -z, yaw 90 -> +x */
    dest[0] = sinf(y) * cosf(p);
    dest[1] = sinf(p);
    dest[2] = -cosf(y) * cosf(p);
}

void hz_camera_view(const hz_camera *c, mat4 dest)
{
    /* Built from the angles, in double, with the right vector from the yaw
     * (as hz_camera_frustum does). NOTE: glm_look(eye, dir, up) forms
     * eye + dir: 50 km from the origin a float's step is 4 mm, so a view
     * within 0.1 degree of straight down lost the horizontal part of dir,
     * became parallel to up, and the view matrix degenerated (a blank image). */
    double pitch = glm_rad(glm_clamp(c->pitch, -89.9f, 89.9f)), yaw = glm_rad(c->yaw);
    double f[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    double r[3] = {cos(yaw), 0.0, sin(yaw)}; /* f x up, normalised */
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    const double e[3] = {c->pos[0], c->pos[1], c->pos[2]};
    glm_mat4_zero(dest);
    for (int k = 0; k < 3; k++) {
        dest[k][0] = (float)r[k];
        dest[k][1] = (float)u[k];
        dest[k][2] = (float)-f[k];
    }
    dest[3][0] = (float)-(r[0] * e[0] + r[1] * e[1] + r[2] * e[2]);
    dest[3][1] = (float)-(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
    dest[3][2] = (float)(f[0] * e[0] + f[1] * e[1] + f[2] * e[2]);
    dest[3][3] = 1.0f;
}

void hz_camera_proj(const hz_camera *c, mat4 dest)
{
    cam_params p = params_of(c);
    /* Built by hand so it is the OpenGL [-w, w] convention whatever cglm's
     * CGLM_FORCE_DEPTH_ZERO_TO_ONE setting is. */
    float f = 1.0f / tanf(p.fov * 0.5f);
    glm_mat4_zero(dest);
    dest[0][0] = f / p.aspect;
    dest[1][1] = f;
    dest[2][2] = -(p.zfar + p.znear) / (p.zfar - p.znear);
    dest[2][3] = -1.0f;
    dest[3][2] = -2.0f * p.zfar * p.znear / (p.zfar - p.znear);
}

void hz_camera_proj_reverse_z(const hz_camera *c, mat4 dest)
{
    cam_params p = params_of(c);
    float f = 1.0f / tanf(p.fov * 0.5f);
    glm_mat4_zero(dest);
    dest[0][0] = f / p.aspect;
    dest[1][1] = f;
    /* z_ndc = (A z + B) / -z with depth 1 at -near and 0 at -far */
    dest[2][2] = p.znear / (p.zfar - p.znear);
    dest[2][3] = -1.0f;
    dest[3][2] = p.zfar * p.znear / (p.zfar - p.znear);
}

void hz_camera_viewproj(const hz_camera *c, mat4 dest)
{
    mat4 v, pr;
    hz_camera_view(c, v);
    hz_camera_proj(c, pr);
    glm_mat4_mul(pr, v, dest);
}

void hz_camera_frustum(const hz_camera *c, vec4 planes[6])
{
    /* Built geometrically in double rather than extracted from proj * view:
     * the extraction loses ~1e-4 relative precision on the far plane. */
    cam_params p = params_of(c);
    double pitch = glm_rad(glm_clamp(c->pitch, -89.9f, 89.9f)), yaw = glm_rad(c->yaw);
    double f[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    double r[3] = {cos(yaw), 0.0, sin(yaw)}; /* f x up, normalised */
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double tv = tan(p.fov * 0.5), th = tv * p.aspect;
    const double e[3] = {c->pos[0], c->pos[1], c->pos[2]};
    double n[6][3];
    for (int k = 0; k < 3; k++) {
        n[0][k] = r[k] + th * f[k];  /* left */
        n[1][k] = -r[k] + th * f[k]; /* right */
        n[2][k] = u[k] + tv * f[k];  /* bottom */
        n[3][k] = -u[k] + tv * f[k]; /* top */
        n[4][k] = f[k];              /* near */
        n[5][k] = -f[k];             /* far */
    }
    for (int i = 0; i < 6; i++) {
        double len = sqrt(n[i][0] * n[i][0] + n[i][1] * n[i][1] + n[i][2] * n[i][2]);
        double d = 0;
        for (int k = 0; k < 3; k++) {
            n[i][k] /= len;
            d -= n[i][k] * e[k];
        }
        if (i == 4)
            d -= p.znear;
        if (i == 5)
            d += p.zfar;
        planes[i][0] = (float)n[i][0];
        planes[i][1] = (float)n[i][1];
        planes[i][2] = (float)n[i][2];
        planes[i][3] = (float)d;
    }
}

void hz_camera_mirror_y(const hz_camera *c, float plane_y, hz_camera *dest)
{
    hz_camera m = *c;
    m.pos[1] = 2.0f * plane_y - c->pos[1];
    m.pitch = -c->pitch;
    /* The mirrored camera sees the mirrored world: its ground bends up. */
    m.earth_radius = -c->earth_radius;
    *dest = m;
}

void hz_camera_curve_box(const hz_camera *cam, float box[2][3])
{
    const float R = cam->earth_radius;
    if (R == 0.0f)
        return;
    const float ex = cam->pos[0], ez = cam->pos[2];
    /* Nearest point of the rectangle (clamped eye) and farthest corner. */
    const float nx = ex < box[0][0] ? box[0][0] : (ex > box[1][0] ? box[1][0] : ex);
    const float nz = ez < box[0][2] ? box[0][2] : (ez > box[1][2] ? box[1][2] : ez);
    const float fx = fabsf(box[0][0] - ex) > fabsf(box[1][0] - ex) ? box[0][0] : box[1][0];
    const float fz = fabsf(box[0][2] - ez) > fabsf(box[1][2] - ez) ? box[0][2] : box[1][2];
    const float far = hz_curvature_drop(R, fx - ex, fz - ez), near = hz_curvature_drop(R, nx - ex, nz - ez);
    box[0][1] -= far > near ? far : near; /* R < 0 (mirrored): the near point drops most */
    box[1][1] -= far > near ? near : far;
}

void hz_camera_curve_sphere(const hz_camera *cam, float c[3], float *r)
{
    const float R = cam->earth_radius;
    if (R == 0.0f)
        return;
    const float dx = c[0] - cam->pos[0], dz = c[2] - cam->pos[2], d = sqrtf(dx * dx + dz * dz);
    const float drop = hz_curvature_drop(R, dx, dz);
    /* d^2 / 2R over [d - r, d + r]: it varies by at most (2 d r + r^2) / 2|R|. */
    c[1] -= drop;
    *r += (2.0f * d * *r + *r * *r) / (2.0f * fabsf(R));
}

float hz_curvature_radius(hz_curvature_mode mode, float extent, float radius)
{
    if (mode == HZ_CURVATURE_OFF || (mode == HZ_CURVATURE_AUTO && !(extent > HZ_CURVATURE_AUTO_EXTENT)))
        return 0.0f;
    return radius > 0.0f ? radius : (float)HZ_EARTH_RADIUS;
}

double hz_wgs84_radius(double lat_deg)
{
    const double a = 6378137.0, e2 = 6.69437999014e-3;
    const double s = sin(lat_deg * 3.14159265358979323846 / 180.0);
    return a * sqrt(1.0 - e2) / (1.0 - e2 * s * s);
}

hz_camera hz_camera_summit_view(const float rect[4], const float centre[2], const float focus[3], float relief,
                                float extent, hz_ground_fn ground, void *user, uint32_t width, uint32_t height)
{
    const float fx = focus[0], fh = focus[1], fz = focus[2];
    const float side = fminf(rect[2] - rect[0], rect[3] - rect[1]);
    /* Back from the summit toward the middle of the map (so the view crosses
     * the map), far enough for the relief to fill the view. */
    const float dist = fminf(fmaxf(3.0f * relief, 0.08f * side), 0.35f * side);
    float dx = centre[0] - fx, dz = centre[1] - fz, len = sqrtf(dx * dx + dz * dz);
    if (len < 0.1f * side) {
        /* A summit near the middle: seen from the south-south-west (yaw 30). */
        dx = -sinf(glm_rad(30.0f));
        dz = cosf(glm_rad(30.0f));
    } else {
        dx /= len;
        dz /= len;
    }
    hz_camera c = {0};
    c.pos[0] = glm_clamp(fx + dist * dx, rect[0], rect[2]);
    c.pos[2] = glm_clamp(fz + dist * dz, rect[1], rect[3]);
    const float hx = fx - c.pos[0], hz = fz - c.pos[2], hd = fmaxf(sqrtf(hx * hx + hz * hz), 1.0f);
    /* Above the summit (nothing hides it) and above the ground under the eye. */
    float under = ground ? ground(user, c.pos[0], c.pos[2]) : -INFINITY;
    c.pos[1] = fh + 0.2f * relief + 0.005f * side;
    if (isfinite(under))
        c.pos[1] = fmaxf(c.pos[1], under + 0.05f * relief + 2.0f);
    c.yaw = glm_deg(atan2f(hx, -hz));
    /* Aim a little below the summit: it sits above the middle of the image,
     * its slopes below. */
    c.pitch = -glm_deg(atanf((c.pos[1] - (fh - 0.3f * relief)) / hd));
    c.fov_y = 60.0f;
    c.aspect = height ? (float)width / (float)height : 16.0f / 9.0f;
    c.znear = 0.25f; /* reverse-Z float depth: a near plane this close costs no precision */
    c.zfar = 1.5f * extent;
    return c;
}
