"""The beam pendulum of examples/beam_pendulum.yaml in Exudyn: run in the peers' own venv.

python exudyn_beam_pendulum.py DT [dense|sparse]   prints one JSON line: process CPU time of the
solve (s), steps, and the tip position at the step starts on the 0.01 s grid (every
0.01 s when DT divides it) and at the end.

The same 2.4 m beam (the paper's beam-slider section), 40 kg tip body, spherical pin at the
root, released horizontally under gravity, 2 s. Exudyn's geometrically exact 3-D beam is linear
(2 nodes), so the mesh has 3× as many elements as flexdyn's 12 cubic ones: the same 37 nodes.
Gravity acts on the beam as the consistent nodal forces of linear elements (half of each
element's weight at either end), exactly what a linear element's load integral gives.
Exudyn's default implicit solver: generalized-α (spectral radius 0.9), modified Newton; its
default linear solver is dense (EXUdense), `sparse` selects EigenSparse (2.6× faster here).
"""

import itertools
import json
import sys
import time
from pathlib import Path

import exudyn as exu
import numpy as np
from exudyn.utilities import (
    Force,
    MarkerBodyPosition,
    MarkerNodePosition,
    MarkerNodeRigid,
    NodeRigidBodyEP,
    ObjectBeamGeometricallyExact,
    ObjectGround,
    ObjectRigidBody,
    SphericalJoint,
    eulerParameters0,
)

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from beam_section import BEAM_SECTION

LENGTH, T_END, SAMPLE = 2.4, 2.0, 0.01
TIP_MASS, TIP_INERTIA, G = 40.0, [0.45, 0.225, 0.225], 9.81


def build(elements):
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    s = BEAM_SECTION
    section = exu.BeamSection()
    # Exudyn's beam axis is local x, the section spanned by local y (flexdyn's axis 2, here
    # the vertical) and z: stiffness [EA, GA_y, GA_z, GJ, EI_y, EI_z].
    section.stiffnessMatrix = np.diag([s["ea"], s["ga2"], s["ga3"], s["gj"], s["ei2"], s["ei3"]])
    section.inertia = np.diag([s["i22"] + s["i33"], s["i22"], s["i33"]])
    section.massPerLength = s["m"]
    le = LENGTH / elements
    nodes = [
        mbs.AddNode(NodeRigidBodyEP(referenceCoordinates=[le * k, 0, 0] + list(eulerParameters0)))
        for k in range(elements + 1)
    ]
    for a, b in itertools.pairwise(nodes):
        mbs.AddObject(ObjectBeamGeometricallyExact(nodeNumbers=[a, b], physicsLength=le, sectionData=section))
    for k, n in enumerate(nodes):
        share = 0.5 if k in (0, elements) else 1.0
        mbs.AddLoad(
            Force(
                markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=n)),
                loadVector=[0, -G * s["m"] * le * share, 0],
            )
        )
    tip = nodes[-1]
    mbs.AddObject(
        ObjectRigidBody(physicsMass=TIP_MASS, physicsInertia=TIP_INERTIA + [0, 0, 0], nodeNumber=tip)
    )
    mbs.AddLoad(
        Force(
            markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=tip)), loadVector=[0, -G * TIP_MASS, 0]
        )
    )
    ground = mbs.AddObject(ObjectGround(referencePosition=[0, 0, 0]))
    m_ground = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0]))
    m_root = mbs.AddMarker(MarkerNodeRigid(nodeNumber=nodes[0]))
    mbs.AddObject(SphericalJoint(markerNumbers=[m_ground, m_root], constrainedAxes=[1, 1, 1]))
    mbs.Assemble()
    return sc, mbs, tip


def run(dt, linear_solver="sparse", elements=36):
    _, mbs, tip = build(elements)
    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.endTime = T_END
    ti.numberOfSteps = round(T_END / dt)
    ti.verboseMode = 0
    settings.solutionSettings.writeSolutionToFile = False
    settings.solutionSettings.sensorsWritePeriod = SAMPLE
    settings.displayStatistics = False
    if linear_solver == "sparse":
        settings.linearSolverType = exu.LinearSolverType.EigenSparse
    times, samples = [], []

    def record(mbs_, t_end_of_step):
        # Called before every step with the time the step will reach; the state is still the
        # step's start, t - dt. Keep the tip at the step starts on the 0.01 s grid.
        t = t_end_of_step - dt
        k = round(t / SAMPLE)
        if abs(t - k * SAMPLE) < 1e-9 and (not times or k * SAMPLE > times[-1]):
            times.append(k * SAMPLE)
            samples.append(list(mbs_.GetNodeOutput(tip, exu.OutputVariableType.Position)))
        return True

    mbs.SetPreStepUserFunction(record)
    t0 = time.process_time()
    ok = exu.SolveDynamic(mbs, settings)
    cpu = time.process_time() - t0
    times.append(T_END)
    samples.append(list(mbs.GetNodeOutput(tip, exu.OutputVariableType.Position)))
    jacobians = mbs.sys["dynamicSolver"].it.newtonJacobiCount
    return {
        "ok": bool(ok),
        "cpu": cpu,
        "steps": int(ti.numberOfSteps),
        "factorizations": jacobians,
        "times": times,
        "tip": samples,
    }


if __name__ == "__main__":
    dt = float(sys.argv[1])
    print(json.dumps(run(dt, sys.argv[2] if len(sys.argv) > 2 else "sparse")))
