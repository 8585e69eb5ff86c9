-- Fixture for tests/test_checkpoints.sh: a small 2D run with everything a checkpoint must carry:
-- hardening sand, an emitter (owed mass, emitted count), a collider moved by a motion function
-- and one by constant velocity.
return {
  dim = 2, dx = 0.006,
  fps = 48, frames = 24,
  domain = { min = {0, 0}, max = {1, 0.5} },
  materials = { sand = { hardening = {35, 9, 0.3, 10}, E = 1e4 } },
  objects = { { shape = { type = "box", center = {0.5, 0.12}, half_extent = {0.15, 0.05} } } },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.03}, normal = {0, 1} }, mode = "slip", friction = 0.5 },
    { shape = { type = "sphere", center = {0, 0}, radius = 0.03 }, mode = "separate",
      motion = function(t)
        return {0.3 + 0.5 * t, 0.25 - 0.3 * t}
      end },
    { shape = { type = "box", center = {0, 0}, half_extent = {0.05, 0.01} }, mode = "sticky",
      position = {0.75, 0.3}, angular_velocity = 2 },
  },
  emitters = { { shape = { type = "sphere", center = {0.4, 0.4}, radius = 0.03 }, rate = params.rate or 20, velocity = {0, -0.5} } },
  outputs = { ply = true, vtk = true, csv = true },
}
