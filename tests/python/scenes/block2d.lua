-- A 2D block of sand (x 0.35..0.65, y 0.1..0.3) falling to the domain floor: no colliders, no camera
-- (tests/python/test_scene.py: the renderer's fitted view).
return {
  dim = 2, dx = params.dx or 0.02, ppc = 4, fps = 24, frames = 2,
  domain = { min = {0, 0}, max = {1, 0.6} },
  materials = { sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.5, 0.2}, half_extent = {0.15, 0.1} }, material = "sand" } },
}
