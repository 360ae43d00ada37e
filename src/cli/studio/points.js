// Small boxes drawn as one point each. A software renderer (SwiftShader) pays about a
// microsecond for every triangle it sets up, however few pixels it covers: a box a few pixels
// across costs six triangles as a hexagon, but one point whose fragment shader casts the eye's
// ray at the box (the face it enters by, lit as the hexagon lights it, at its true depth) draws
// the same picture for less. Big boxes keep the hexagon: there the point's square and its
// shader cost more than the triangles. Only boxes wholly inside the viewport become points
// (a point whose centre leaves the viewport is clipped whole). BENCH.md, issue #21.

import * as THREE from './three.module.min.js';

// A box's hexagon (app.js): its near corner 0 and the ring 1..6 around it; faces +y (1 2 3),
// +z (3 4 5), +x (5 6 1), each as two triangles from the near corner.
export const HEXAGON_TRIANGLES = [0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 1];

// Largest point [drawing-buffer pixels]: beyond it the hexagon is cheaper.
export const POINT_MAX_PX = 16;

// The eye's angle to a sphere's centre, and the sphere's angular radius, beyond which its
// projection is too stretched to bound well (the box is drawn as a hexagon).
const MAX_ANGLE = 1.3;

// Half the side [pixels] of a screen square centred on the projection of a sphere's centre
// (view space `x y z`, radius `r`) that holds the sphere's whole projection, with `f` pixels per
// unit of the image plane at distance 1; or -1 when there is no such bound worth drawing. The
// far edge of the projected ellipse is the farthest from the centre's projection, so
// tan(θ + α) − tan(θ) bounds it, θ the centre's angle off the view axis, α the sphere's
// angular radius. The vertex shader's `halfSide` is the same formula.
export function halfSide(x, y, z, r, f) {
  const distance = Math.hypot(x, y, z);
  if (-z - r <= 0 || distance <= r) return -1;
  const theta = Math.acos(-z / distance);
  const alpha = Math.asin(r / distance);
  if (theta + alpha > MAX_ANGLE) return -1;
  return f * (Math.tan(theta + alpha) - Math.tan(theta));
}

const GLSL_HALF_SIDE = `float halfSide(vec3 c, float r, float f) {
  float distance = length(c);
  float theta = acos(clamp(-c.z / distance, -1.0, 1.0));
  float alpha = asin(clamp(r / distance, 0.0, 1.0));
  return f * (tan(theta + alpha) - tan(theta));
}`;

// Per free box group: which members are points this frame. Fills `pointIndex` with the members
// drawn as points and `hexIndex` with the hexagon triangles of the rest (18 indices a member,
// 7 corners apart), and says whether either changed. The poses are read from the group's pose
// texture (8 floats a member: position, then the quaternion).
export function chooseDetail(g, camera, width, height) {
  const view = camera.matrixWorldInverse.elements;
  const p = camera.projectionMatrix.elements;
  // Pixels per unit of the image plane at distance 1 (square pixels: the same along x and y).
  const f = 0.5 * height * p[5];
  const d = g.poses.image.data;
  const n = g.members.length;
  let points = 0;
  let hexes = 0;
  let changed = false;
  for (let k = 0; k < n; k++) {
    const wx = d[8 * k];
    const wy = d[8 * k + 1];
    const wz = d[8 * k + 2];
    const x = view[0] * wx + view[4] * wy + view[8] * wz + view[12];
    const y = view[1] * wx + view[5] * wy + view[9] * wz + view[13];
    const z = view[2] * wx + view[6] * wy + view[10] * wz + view[14];
    const half = halfSide(x, y, z, g.radius, f);
    // The point's side as the vertex shader sizes it.
    let point = half >= 0 && 2 * half + 1 <= POINT_MAX_PX;
    if (point) {
      // The centre's pixel, and the square around it, inside the viewport.
      const sx = 0.5 * width * (1 + (p[0] * x + p[8] * z) / -z);
      const sy = 0.5 * height * (1 + (p[5] * y + p[9] * z) / -z);
      const reach = half + 1;
      point = sx - reach >= 0 && sx + reach <= width && sy - reach >= 0 && sy + reach <= height;
    }
    if (point) {
      if (g.pointIndex[points] !== k) changed = true;
      g.pointIndex[points++] = k;
    } else {
      const at = 18 * hexes++;
      if (g.hexIndex[at] !== HEXAGON_TRIANGLES[0] + 7 * k) changed = true;
      for (let j = 0; j < 18; j++) g.hexIndex[at + j] = HEXAGON_TRIANGLES[j] + 7 * k;
    }
  }
  changed ||= points !== g.points || hexes !== g.hexes;
  g.points = points;
  g.hexes = hexes;
  return changed;
}

// The points' material: per point (one a member, attribute `body`) the box of half extents
// `extent` at its member's pose, coloured per point. `uniforms` holds the lights (as the
// hexagons' material has them), `projection` (the camera's matrix) and `viewport` (the drawing
// buffer's, in pixels).
export function pointBoxMaterial(poses, extent, poseWidth, uniforms) {
  return new THREE.ShaderMaterial({
    uniforms: {
      poses: { value: poses },
      extent: { value: new THREE.Vector3(...extent) },
      radius: { value: Math.hypot(...extent) },
      ...uniforms,
    },
    vertexColors: true,
    vertexShader: `attribute float body;
uniform highp sampler2D poses;
uniform vec3 sky, ground, up, sunColor, sunDir;
uniform vec3 extent;
uniform float radius;
uniform vec4 viewport;
flat varying vec3 vLow, vHigh, vRayX, vRayY, vRay0;
flat varying vec3 vLitX, vLitY, vLitZ;
vec3 turn(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }
vec4 poseTexel(int i) { return texelFetch(poses, ivec2(i % ${poseWidth}, i / ${poseWidth}), 0); }
// As the hexagons' shader lights a face of outward normal nl in the body's frame.
vec3 light(vec4 q, vec3 nl) {
  vec3 n = normalize(turn(q, nl));
  vec3 irradiance = mix(ground, sky, 0.5 * dot(n, up) + 0.5) + max(dot(n, sunDir), 0.0) * sunColor;
  return color * irradiance * 0.3183098861837907;
}
${GLSL_HALF_SIDE}
void main() {
  vec4 at = poseTexel(int(body) * 2);
  vec4 q = poseTexel(int(body) * 2 + 1);
  vec3 eye = turn(vec4(-q.xyz, q.w), cameraPosition - at.xyz);
  vLitX = light(q, vec3(eye.x < 0.0 ? -1.0 : 1.0, 0.0, 0.0));
  vLitY = light(q, vec3(0.0, eye.y < 0.0 ? -1.0 : 1.0, 0.0));
  vLitZ = light(q, vec3(0.0, 0.0, eye.z < 0.0 ? -1.0 : 1.0));
  vec4 centre = modelViewMatrix * vec4(at.xyz, 1.0);
  mat3 boxToWorld = mat3(turn(q, vec3(1.0, 0.0, 0.0)), turn(q, vec3(0.0, 1.0, 0.0)), turn(q, vec3(0.0, 0.0, 1.0)));
  mat3 toBox = transpose(mat3(viewMatrix) * boxToWorld);
  // The box's faces from the eye in the box's frame, and the eye's ray through a pixel there,
  // linear in the pixel's coordinates: in view space (ndc.x + P[2][0]) / P[0][0],
  // (ndc.y + P[2][1]) / P[1][1], -1.
  vec3 origin = toBox * -centre.xyz;
  vLow = -extent - origin;
  vHigh = extent - origin;
  vRayX = toBox[0] * (2.0 / (viewport.z * projectionMatrix[0][0]));
  vRayY = toBox[1] * (2.0 / (viewport.w * projectionMatrix[1][1]));
  vRay0 = toBox * vec3((projectionMatrix[2][0] - 1.0 - 2.0 * viewport.x / viewport.z) / projectionMatrix[0][0],
                       (projectionMatrix[2][1] - 1.0 - 2.0 * viewport.y / viewport.w) / projectionMatrix[1][1], -1.0);
  gl_PointSize = 2.0 * halfSide(centre.xyz, radius, 0.5 * viewport.w * projectionMatrix[1][1]) + 1.0;
  gl_Position = projectionMatrix * centre;
}`,
    fragmentShader: `uniform mat4 projection;
flat varying vec3 vLow, vHigh, vRayX, vRayY, vRay0;
flat varying vec3 vLitX, vLitY, vLitZ;
void main() {
  // The eye's ray through this pixel in the box's frame (one unit along the view's -z per unit
  // of t); the slabs give where it enters and leaves the box.
  vec3 inverse = 1.0 / (vRayX * gl_FragCoord.x + vRayY * gl_FragCoord.y + vRay0);
  vec3 t0 = vLow * inverse;
  vec3 t1 = vHigh * inverse;
  vec3 near = min(t0, t1);
  vec3 far = max(t0, t1);
  float enter = max(max(near.x, near.y), near.z);
  if (enter > min(min(far.x, far.y), far.z)) discard;
  vec3 lit = enter == near.x ? vLitX : enter == near.y ? vLitY : vLitZ;
  float z = -enter;
  gl_FragDepth = 0.5 * (projection[2][2] * z + projection[3][2]) / -z + 0.5;
  gl_FragColor = vec4(lit, 1.0);
#include <tonemapping_fragment>
#include <colorspace_fragment>
}`,
  });
}
