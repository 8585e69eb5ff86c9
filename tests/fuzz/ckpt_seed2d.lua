-- Seed scene for the checkpoint fuzzer's corpus (tests/fuzz/make_checkpoint_seeds.sh): a 2D world
-- small enough that a whole checkpoint fits in the fuzzer's 32 KB inputs, with everything a
-- checkpoint carries: hardening sand, an emitter, a collider moved by a motion function and one
-- by a constant angular velocity.
return {
  dim = 2, dx = 0.05, ppc = 4,
  fps = 30, frames = 3,
  domain = { min = {0, 0}, max = {1, 0.6} },
  materials = { sand = { hardening = {35, 9, 0.3, 10}, E = 1e4 } },
  objects = { { shape = { type = "box", center = {0.5, 0.2}, half_extent = {0.15, 0.06} } } },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.12}, normal = {0, 1} }, mode = "slip", friction = 0.5 },
    { shape = { type = "sphere", center = {0, 0}, radius = 0.05 }, mode = "separate",
      motion = function(t)
        return {0.3 + 0.5 * t, 0.4 - 0.3 * t}
      end },
    { shape = { type = "box", center = {0, 0}, half_extent = {0.06, 0.02} }, mode = "sticky",
      position = {0.8, 0.35}, angular_velocity = 2 },
  },
  emitters = { { shape = { type = "sphere", center = {0.4, 0.45}, radius = 0.06 }, rate = 200, velocity = {0, -0.5} } },
  outputs = { ply = false, vtk = false, csv = false },
}
