-- docs/validation.md section 9, "Time step": two blocks colliding head-on at 1 m/s each in free space
-- (2D, no gravity, no colliders). --set model=sand (phi 30) or elastic; --set elastic_cfl=...; --set transfer=...
-- Total energy (diagnostics.csv: kinetic + elastic) at 0.2 and 0.5 s against elastic_cfl. Made on commit 17ac394.
local P = params
local dx = 0.01
return {
  dim = 2, dx = dx, ppc = 4, elastic_cfl = P.elastic_cfl or 0.5, transfer = P.transfer or "apic",
  fps = 20, frames = 10, gravity = {0, 0},
  domain = { min = {0, 0}, max = {1, 0.6} },
  materials = { m = { model = P.model or "elastic", density = 2200, E = 3.537e5, nu = 0.3,
                       friction_angle = (P.model == "sand") and 30 or nil } },
  objects = {
    { shape = { type = "box", center = {0.35, 0.3}, half_extent = {0.1, 0.1} }, material = "m", velocity = {1, 0} },
    { shape = { type = "box", center = {0.65, 0.3}, half_extent = {0.1, 0.1} }, material = "m", velocity = {-1, 0} },
  },
  outputs = { ply = false, vtk = false, csv = true },
}
