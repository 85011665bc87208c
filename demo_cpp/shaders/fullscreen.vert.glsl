#version 430 core
// One triangle covering the viewport; no vertex buffer needed. The view's uniforms are
// read here, three times a frame, and handed to the fragment shader as flat inputs: on
// llvmpipe a fragment shader reads each uniform lane by lane, an input once per block.
uniform vec3 u_cam_origin;
uniform vec3 u_cam_forward;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform float u_half_height;  // tan(fov_y / 2)
uniform vec2 u_size;          // width, height in pixels
uniform int u_strata;         // k: k x k stratum centres per pixel
uniform int u_display;        // 1: clamp and sRGB-encode (window), 0: linear (headless)

flat out vec3 cam_origin;
flat out vec3 cam_forward;
flat out vec3 cam_right;
flat out vec3 cam_up;
flat out float half_height;
flat out vec2 size;
flat out int strata;
flat out int display;

void main() {
    vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
    cam_origin = u_cam_origin;
    cam_forward = u_cam_forward;
    cam_right = u_cam_right;
    cam_up = u_cam_up;
    half_height = u_half_height;
    size = u_size;
    strata = u_strata;
    display = u_display;
}
