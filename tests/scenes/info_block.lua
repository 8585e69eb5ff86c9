-- Fixture for tests/test_cli_info.sh: a block of 3D sand large enough (about 144,000 particles)
-- that a run's memory is mostly its particles, in frames short enough (2 ms) that two frames and
-- their checkpoints take seconds. `info` estimates the run's steps, disk and memory; the test runs
-- the scene and compares.
return {
  dim = 3, dx = 0.01, ppc = 8, fps = 500, frames = 2, checkpoint_every = 1,
  domain = { min = {0, 0, 0}, max = {0.5, 0.4, 0.5} },
  materials = { sand = { model = "sand", density = 1500, E = 1e5, nu = 0.3, friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.25, 0.15, 0.25}, size = {0.3, 0.2, 0.3} }, material = "sand" } },
  colliders = { { shape = { type = "halfspace", point = {0, 0.04, 0}, normal = {0, 1, 0} }, mode = "sticky" } },
}
