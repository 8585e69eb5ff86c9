-- docs/validation.md section 9, "Time step": an elastic bar (E = 1e4) spinning at 20 rad/s in free space
-- (2D, no gravity): total energy at 0.5 and 1 s against --set elastic_cfl=... Made on commit 17ac394.
local P = params
local dx = 0.01
return {
  dim = 2, dx = dx, ppc = 4, elastic_cfl = P.elastic_cfl or 0.5, transfer = P.transfer or "apic",
  fps = 20, frames = 20, gravity = {0, 0},
  domain = { min = {0, 0}, max = {1, 1} },
  materials = { m = { model = P.model or "elastic", density = 1000, E = 1e4, nu = 0.3 } },
  objects = {
    { shape = { type = "box", center = {0.5, 0.5}, half_extent = {0.15, 0.05} }, material = "m", angular_velocity = 20 },
  },
  outputs = { ply = false, vtk = false, csv = true },
}
