-- Fixture for tests/test_scene.c: a 2D scene (2-component vectors, default ppc 4, the only
-- material used by default, end_time instead of frames).
return {
  dim = 2, dx = 0.01,
  fps = 24, end_time = 0.1,
  domain = { min = {0, 0}, max = {1, 0.5} },
  gravity = {0, -9.81},
  materials = { sand = { hardening = {35, 9, 0.3, 10}, E = 1e4 } },
  objects = { { shape = { type = "box", center = {0.5, 0.1}, half_extent = {0.2, 0.05} } } },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.03}, normal = {0, 1} }, mode = "slip", friction = 0.5 },
    { shape = { type = "box", center = {0, 0}, half_extent = {0.05, 0.01}, axis_angle = {0, 0, 1, 45} },
      mode = "separate", position = {0.8, 0.4}, angular_velocity = 2 },   -- rad/s about z
  },
}
