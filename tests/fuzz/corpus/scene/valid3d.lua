-- Fixture for tests/test_scene.c: a 3D scene that uses most keys (the test checks that each one
-- reaches the world). Two materials, a rotated box and a Poisson-sampled sphere, a sticky ground and
-- a moving collider made of two shapes.
local dx = params.dx or 0.02
return {
  dim = 3, dx = dx, ppc = 8, kernel = "cubic", transfer = "flip", flip_ratio = 0.9,
  integrator = "explicit", cfl = 0.5, max_dt = 5e-4, elastic_cfl = 0.4,
  fps = 30, end_time = 0.5,
  gravity = {0, -5, 0}, seed = 7,
  static_friction_sticks = false, particle_projection = false, contact_gap = 0.5,
  domain = { min = {0, 0, 0}, max = {0.6, 0.5, 0.4}, walls = "slip", wall_friction = 0.25 },
  materials = {
    sand = { model = "sand", density = 2000, E = 2e5, nu = 0.25, friction_angle = 30 },
    rubber = { model = "elastic", density = 1200, E = 5e4, nu = 0.4 },
  },
  objects = {
    { shape = { type = "box", center = {0.2, 0.1, 0.2}, size = {0.2, 0.1, 0.16}, axis_angle = {0, 1, 0, 30} },
      material = "sand", velocity = {0.5, 0, 0} },
    { shape = { type = "sphere", center = {0.45, 0.25, 0.2}, radius = 0.06 }, material = "rubber", ppc = 4,
      sampling = "poisson", angular_velocity = {0, 0, 1} },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.04, 0}, normal = {0, 1, 0} }, mode = "sticky" },
    { shapes = {
        { type = "cylinder", center = {0, 0, 0}, radius = 0.03, height = 0.1 },
        { type = "box", center = {0, 0.06, 0}, half_extent = {0.05, 0.01, 0.05}, rotation = {1, 0, 0, 0} },
      },
      mode = "separate", friction = 0.4, position = {0.45, 0.3, 0.1}, velocity = {0, -0.1, 0} },
  },
  outputs = { vtk = false },
  camera = { eye = {1, 1, 1}, target = {0.3, 0.1, 0.2}, fov = 35 },
}
