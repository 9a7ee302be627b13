"""A small wind turbine built with the building blocks (README, "A worked example"): a flexible
steel tower, a nacelle, a horizontal shaft spun up from rest, and three aluminium blades on
pitch bearings — written once and patterned about the shaft — with cyclic pitch, structural
damping, and root loads in each blade's own section frame.

    python3 examples/wind_turbine.py            # 6 s, writes wind_turbine.nc and a plot
"""

import flexdyn as fd
from flexdyn.plots import plot

OMEGA = 3.0  # rotor speed after the spin-up, rad/s
T_UP = 2.0  # spin-up time, s: smooth from rest (docs/expressions.md)
HUB = [0.0, 0.0, 12.0]  # m


def wind_turbine(t_end=6.0):
    m = fd.Model("wind turbine", gravity=[0, 0, -9.81])

    # Tower: a 12 m steel tube clamped to the ground, 1 % damping at its first bending mode.
    steel = {"E": 2.1e11, "G": 8.1e10, "density": 7850}
    tower = {"material": steel, "shape": {"tube": {"diameter": 0.5, "wall": 0.012}}}
    m.beam("tower", [0, 0, 0], HUB, elements=3, section=tower, damping={"ratio": 0.01, "frequency": 2.5})
    m.clamp("foundation", "ground", "tower.start")

    # Nacelle on the tower top; the hub turns on a shaft along x, spun up smoothly from rest.
    m.node("nacelle", HUB).body("nacelle_mass", "nacelle", mass=400.0, inertia=[50, 80, 80])
    m.clamp("yaw_lock", "tower.end", "nacelle")
    m.node("hub", HUB).body("hub_mass", "hub", mass=150.0, inertia=[30, 20, 20])
    spin_up = f"t < {T_UP} ? {OMEGA}*{T_UP}*((t/{T_UP})^3 - (t/{T_UP})^4/2) : {OMEGA}*(t - {T_UP}/2)"
    m.revolute("shaft", "nacelle", "hub", axis=[1, 0, 0], drive=spin_up)

    # Three blades, written once: a pitch bearing 0.4 m up the hub's z axis, a 6 m aluminium
    # box blade along the bearing's z axis, placed in the bearing's frame, and cyclic pitch
    # with a phase of 120° per blade ({i} is the blade's number). Each blade's section axis 2
    # is the bearing's y (the default rule in its frame), so M2 is flap and M3 edgewise alike
    # for all three.
    aluminium = {"E": 7.0e10, "G": 2.6e10, "density": 2700}
    blade = {"material": aluminium, "shape": {"box": {"width": 0.25, "height": 0.08, "wall": 0.004}}}
    with m.pattern("rotor", count=3, axis=[1, 0, 0], center=HUB) as p:
        p.node("pitch{i}", [0, 0, 0.4], frame="hub").body(
            "bearing{i}", "pitch{i}", mass=5.0, inertia=[0.1] * 3
        )
        p.revolute(
            "pitch_bearing{i}",
            "hub",
            "pitch{i}",
            axis=[0, 0, 1],
            frame="node2",
            drive="0.05*sin(t*2*pi/3 + 2*pi*({i} - 1)/3)*smoothstep(0, 1, t)",
        )
        p.beam(
            "blade{i}",
            [0, 0, 0],
            [0, 0, 6.0],
            frame="pitch{i}",
            elements=4,
            section=blade,
            damping={"ratio": 0.01, "frequency": 3.0},
        )
        p.clamp("blade_root{i}", "pitch{i}", "blade{i}.start")
        p.sensor("beam_section", "root{i}", beam="blade{i}", eta=0.02)
        p.sensor("drive_force", "pitch_moment{i}", joint="pitch_bearing{i}")

    m.sensor("beam_section", "tower_base", beam="tower", eta=0.0)
    m.sensor("drive_force", "shaft_torque", joint="shaft")
    m.sensor("energy", "energy")
    # The defaults: ED with adaptive steps; at rest at t = 0 (the shaft and pitch drives start
    # from rest), the turbine starts in its static equilibrium under gravity, the tower and
    # blades sagging, not dropped unstrained into gravity.
    m.simulation(t_end=t_end)
    return m


if __name__ == "__main__":
    res = fd.simulate(wind_turbine(), out="wind_turbine.nc")
    s = res.flexdyn.stats
    print(f"{s['steps']} steps, {s['wall_time_s']:.1f} s; warnings: {res.attrs['warnings'] or 'none'}")
    for k in (1, 2, 3):
        m3 = res[f"root{k}.M3"].values  # edgewise: the blade's weight as it turns
        print(f"blade {k}: root edgewise moment M3 from {m3.min():.0f} to {m3.max():.0f} N·m")
    plot(["wind_turbine.nc"], ["root1.M3", "root2.M3", "root3.M3", "shaft_torque"], out="wind_turbine.png")
