#!/usr/bin/python3
"""Writes the pneumatic humanoid of issue 15 and its motor twin from one joint table.

    scripts/make_humanoid.py            # writes the two models into models_mjcf/
    scripts/make_humanoid.py --table    # also prints each joint's cylinder, lever and capacity

Outputs (all generated; do not edit them by hand):
  models_mjcf/humanoid_pneumatic.xml             every actuated joint driven by a pneumatic cylinder,
                                                 one proportional valve per chamber (paper 000)
  models_mjcf/humanoid_motors.xml                the same bodies, one plain motor per actuated joint
The pneumatic model carries the PID gains it is tuned with, models_mjcf/humanoid_pid.json (written by
hand: README "The humanoid under PID"), as <text name="pneumo:controller:pid">, which
`pneumo rollout --controller pid` uses unless --controller-config replaces it.
Then scripts/identify_humanoid writes models_mjcf/humanoid_pneumatic_identified.xml from the first: every
chamber on paper 000's identified model (pressure_model=identified), c1..c9 fitted to logs of it.

Standard library only (Debian's /usr/bin/python3). Deterministic: the same table gives the same bytes.

Design (the project's own choices unless a source is named):
* Paper 000 (Section V): the Kokoro humanoid, 38 dofs driven directly by linear or rotary cylinders,
  one Festo MPYE valve per chamber, supply 90 psi = 6.2e5 Pa absolute, commands 3..7 V. This robot has
  36 actuated hinges (72 chambers): waist 3, neck 3, each arm 8 (shoulder shrug, shoulder pitch / roll /
  yaw, elbow, forearm twist, wrist pitch / roll), each leg 7 (hip yaw / roll / pitch, knee, ankle
  pitch / roll, toes). Paper 000's 38 controlled dofs included the face; the face is left out.
* The pelvis is welded to a fixed stand (no free joint), as paper 000's robot was identified hanging on
  a stand: no balance is needed and every joint can move freely. Self-collisions are off.
* Linear cylinders (28): Festo DSNU round cylinders between a site on the parent body (<name>.cap)
  and a site on the child (<name>.rod) at lever arm r from the hinge axis, mount=hinge_sites: the
  extension computes the pin-to-pin length and its lever arm from the hinge (the same geometry as a
  spatial tendon over the two sites, without MuJoCo's tendon work each step; plugin/README.md). At
  mid-range the cylinder is perpendicular to the lever, so its length is
  L(q) = sqrt(d^2 + 2 r^2 (1 - cos(q - q_mid)) +- 2 d r sin(q - q_mid))
  (d: pin-to-pin length at mid-stroke). r is chosen so that the length change over the joint range,
  L(q_max) - L(q_min), uses 90 % of the catalogue stroke (5 % margin each end, so that the joint limit,
  not the cylinder's end stop, stops the limb), and x_mid = (L(q_min) + L(q_max)) / 2, so mid-stroke is
  at mid-range. Joint spans of linear cylinders stay <= 140 deg, where the moment arm at the range ends
  is still r cos(70 deg) = 0.34 r.
* Rotary vane cylinders (8, where humanoids twist about a limb's long axis: waist yaw, neck yaw,
  upper-arm yaw, forearm twist, hip yaw): Festo DSM semi-rotary drives directly on the hinge; x is the
  joint angle, stroke = joint span + 10 deg (5 deg margin each end), x_mid = mid-range. Their "area" is
  the displacement per radian D = T / (6e5 Pa), from the catalogue's theoretical torque T at 6 bar
  (T = D * dp for a vane; the swept volume per radian is the same D).
* Valves: rig C of docs/rigs.md (paper 000 eq. 3, thin-plate flow): B = 2 mm^2/V,
  U_c = 5.3 V, U_r = 4.7 V, L_c = L_r = 0.05 mm^2, C = 0.72, Z = 0.99, kappa = 1.4, T = 293 K,
  r = 8.31 / 0.029 J/(kg K); p_supply = 6.2e5 Pa, p_exhaust = 1.0e5 Pa (paper 000: 90 psi, room).
  One valve per chamber is as large for a 10 mm as for a 32 mm bore (paper 000 used MPYE throughout).
* Dead volumes: each chamber's tube from its valve, 0.4 m of Festo PUN tubing (PUN-4x0.75, 2.5 mm
  inside, for bores <= 16 mm and the DSM-8/10/12; PUN-6x1, 4 mm inside, above) plus 0.5 cm^3 of port
  and fitting: 2.46e-6 m^3 and 5.53e-6 m^3.
* Masses: 37.8 kg in all (pelvis 5 kg, torso 9 kg, head 2.5 kg, arm 3.7 kg, leg 6.55 kg), a scaled
  adult of about 1.5 m; each cylinder's mass is lumped into its bodies. Inertias come from the geoms.
* Joint damping: seal and bearing friction as viscous damping, c_seal r^2 with c_seal = 300 N s/m for
  a linear cylinder (r its lever), c_seal = 0.05 N m s/rad for a vane, plus 0.05 N m s/rad for the
  bearing. Timestep 1 ms, Euler: README "Accuracy" puts rig C's chamber step at 0.013 % along a given
  motion at 1 ms, and 0.39 % / 0.33 mm open loop.
* Motor twin: the same bodies, joints, sites, masses and damping; one <motor> per actuated joint with
  gear 1 and ctrlrange +-T_max, T_max = the cylinder's mid-range torque A_P (p_supply - p_exhaust) r
  (A_P D (p_supply - p_exhaust) for a vane).

Catalogue sizes used (Festo DSNU round cylinders, ISO 6432, catalogue: bores 10/12/16/20/25/32 mm
with piston rods 4/6/6/8/10/12 mm; strokes from the catalogue steps 10, 25, 40, 50, 80, 100, 125 mm.
Festo DSM semi-rotary drives, catalogue: theoretical torque at 6 bar 0.5 N m (DSM-8), 1 N m (DSM-10),
1.25 N m (DSM-12), 2.5 N m (DSM-16), 5 N m (DSM-25), swivel angle adjustable up to 270 deg).
"""

import json
import math
import os
import sys
from xml.sax.saxutils import quoteattr

# ---------------------------------------------------------------- constants (see the docstring)
P_SUPPLY = 6.2e5          # Pa abs, paper 000: 90 psi
P_EXHAUST = 1.0e5         # Pa abs, docs/rigs.md rig C
TEMPERATURE = 293.0       # K, docs/rigs.md rig C
GAS_CONSTANT = 8.31 / 0.029   # J/(kg K), paper 000 Table II
TIMESTEP = 0.001          # s, the project's choice (docstring)
# the default view of renders and frames (pneumo render, rollout --frames): three-quarters from the front,
# where the cylinders of the arms and legs and their pressure colours show, with the stand behind the pelvis
VIEW = '  <visual><global azimuth="135" elevation="-15"/></visual>'
STROKE_USE = 0.9          # fraction of a linear cylinder's stroke used by the joint range
VANE_MARGIN = math.radians(5)   # rad, each end of a vane's stroke beyond the joint range
SEAL_DAMPING = 300.0      # N s/m, linear cylinder seal friction as viscous damping (project's choice)
VANE_DAMPING = 0.05       # N m s/rad, vane seal friction (project's choice)
BEARING_DAMPING = 0.05    # N m s/rad, every joint (project's choice)

# Festo DSNU: bore (m) -> piston rod diameter (m)
DSNU_ROD = {0.010: 0.004, 0.012: 0.006, 0.016: 0.006, 0.020: 0.008, 0.025: 0.010, 0.032: 0.012}
DSNU_STROKES = (0.010, 0.025, 0.040, 0.050, 0.080, 0.100, 0.125)
# Festo DSM: size -> theoretical torque at 6 bar (N m)
DSM_TORQUE = {8: 0.5, 10: 1.0, 12: 1.25, 16: 2.5, 25: 5.0}


def tube_dead_volume(small):
    """0.4 m of PUN tube (2.5 mm or 4 mm inside) plus 0.5 cm^3 of port and fitting, m^3."""
    inside = 0.0025 if small else 0.004
    return math.pi * (inside / 2) ** 2 * 0.4 + 0.5e-6


# ---------------------------------------------------------------- the joint table
# name, parent, body position in the parent (m), hinge axis, range (deg), body: mass (kg) and
# geom (capsule "fromto" or sphere radius), cylinder: ("dsnu", bore m, stroke m, lever direction at
# mid-range in the parent frame, direction from the child site toward the parent site) or
# ("dsm", size). Left side only for limbs; the right side is its mirror image (y -> -y).
# Axes: x forward, y left, z up. Pelvis at 1.0 m on the stand.
def arm(side):
    s = 1 if side == "left" else -1
    p = side[0] + "_"
    return [
        # shoulder shrug: the clavicle rotates about the forward axis at the sternum
        (p + "shoulder_shrug", "torso", (0, s * 0.05, 0.42), (1, 0, 0), (-5, 20),
         (0.4, ("capsule", (0, 0, 0, 0, s * 0.13, 0), 0.025)), ("dsnu", 0.020, 0.025, (0, 0, 1), (0, -s, 0))),
        (p + "shoulder_pitch", p + "shoulder_shrug", (0, s * 0.15, 0), (0, 1, 0), (-95, 45),
         (0.2, ("sphere", 0.035)), ("dsnu", 0.025, 0.100, (1, 0, 0), (0, 0, -1))),
        (p + "shoulder_roll", p + "shoulder_pitch", (0, 0, 0), (1, 0, 0), (-10, 90),
         (0.2, ("sphere", 0.03)), ("dsnu", 0.020, 0.080, (0, s, 0), (0, 0, -1))),
        # shoulder yaw: a DSM-25, not a DSM-16: with the arm out and the elbow bent (the wave), the
        # level forearm and hand load this axis with 2.7 N m of weight, over the DSM-16's 2.2 N m at
        # this supply (2.5 N m at 6 bar gauge)
        (p + "shoulder_yaw", p + "shoulder_roll", (0, 0, 0), (0, 0, 1), (-60, 90),
         (1.4, ("capsule", (0, 0, -0.02, 0, 0, -0.26), 0.04)), ("dsm", 25)),
        (p + "elbow", p + "shoulder_yaw", (0, 0, -0.28), (0, 1, 0), (-140, 0),
         (0.9, ("capsule", (0, 0, -0.02, 0, 0, -0.23), 0.033)), ("dsnu", 0.020, 0.080, (1, 0, 0), (0, 0, 1))),
        (p + "forearm_twist", p + "elbow", (0, 0, -0.25), (0, 0, 1), (-80, 80),
         (0.1, ("sphere", 0.025)), ("dsm", 10)),
        (p + "wrist_pitch", p + "forearm_twist", (0, 0, 0), (0, 1, 0), (-60, 60),
         (0.1, ("sphere", 0.022)), ("dsnu", 0.010, 0.025, (1, 0, 0), (0, 0, 1))),
        (p + "wrist_roll", p + "wrist_pitch", (0, 0, 0), (1, 0, 0), (-20, 30),
         (0.4, ("capsule", (0, 0, -0.02, 0, 0, -0.12), 0.03)), ("dsnu", 0.010, 0.010, (0, s, 0), (0, 0, 1))),
    ]


def leg(side):
    s = 1 if side == "left" else -1
    p = side[0] + "_"
    return [
        (p + "hip_yaw", "pelvis", (0, s * 0.1, -0.08), (0, 0, 1), (-30, 45),
         (0.3, ("sphere", 0.04)), ("dsm", 25)),
        (p + "hip_roll", p + "hip_yaw", (0, 0, -0.04), (1, 0, 0), (-30, 30),
         (0.3, ("sphere", 0.04)), ("dsnu", 0.025, 0.050, (0, s, 0), (0, 0, 1))),
        (p + "hip_pitch", p + "hip_roll", (0, 0, 0), (0, 1, 0), (-90, 30),
         (3.0, ("capsule", (0, 0, -0.03, 0, 0, -0.37), 0.06)), ("dsnu", 0.032, 0.125, (1, 0, 0), (0, 0, -1))),
        (p + "knee", p + "hip_pitch", (0, 0, -0.40), (0, 1, 0), (0, 130),
         (2.0, ("capsule", (0, 0, -0.03, 0, 0, -0.37), 0.045)), ("dsnu", 0.032, 0.125, (-1, 0, 0), (0, 0, 1))),
        (p + "ankle_pitch", p + "knee", (0, 0, -0.40), (0, 1, 0), (-40, 25),
         (0.1, ("sphere", 0.03)), ("dsnu", 0.020, 0.050, (1, 0, 0), (0, 0, 1))),
        (p + "ankle_roll", p + "ankle_pitch", (0, 0, 0), (1, 0, 0), (-20, 20),
         (0.7, ("box", (0.06, 0, -0.05), (0.09, 0.045, 0.02))), ("dsnu", 0.016, 0.025, (0, s, 0), (0, 0, 1))),
        (p + "toes", p + "ankle_roll", (0.15, 0, -0.05), (0, 1, 0), (-10, 40),
         (0.15, ("box", (0.03, 0, 0), (0.03, 0.045, 0.015))), ("dsnu", 0.010, 0.025, (0, 0, 1), (-1, 0, 0))),
    ]


TRUNK = [
    ("waist_yaw", "pelvis", (0, 0, 0.12), (0, 0, 1), (-45, 45),
     (0.3, ("sphere", 0.05)), ("dsm", 25)),
    ("waist_pitch", "waist_yaw", (0, 0, 0.04), (0, 1, 0), (-30, 30),
     (0.3, ("sphere", 0.05)), ("dsnu", 0.032, 0.080, (1, 0, 0), (0, 0, -1))),
    ("waist_roll", "waist_pitch", (0, 0, 0), (1, 0, 0), (-20, 20),
     (9.0, ("box", (0, 0, 0.24), (0.1, 0.15, 0.2))), ("dsnu", 0.032, 0.050, (0, 1, 0), (0, 0, -1))),
    ("neck_yaw", "torso", (0, 0, 0.47), (0, 0, 1), (-70, 70),
     (0.1, ("sphere", 0.025)), ("dsm", 12)),
    ("neck_pitch", "neck_yaw", (0, 0, 0.04), (0, 1, 0), (-30, 40),
     (0.1, ("sphere", 0.025)), ("dsnu", 0.016, 0.040, (1, 0, 0), (0, 0, -1))),
    ("neck_roll", "neck_pitch", (0, 0, 0), (1, 0, 0), (-25, 25),
     (2.5, ("sphere_at", (0.01, 0, 0.1), 0.1)), ("dsnu", 0.016, 0.025, (0, 1, 0), (0, 0, -1))),
]

# the body a joint moves is named after the joint, except these (the limbs' names)
BODY_NAME = {"waist_roll": "torso", "neck_roll": "head"}
for _p in ("l_", "r_"):
    BODY_NAME.update({_p + "shoulder_shrug": _p + "clavicle", _p + "shoulder_yaw": _p + "upper_arm",
                      _p + "elbow": _p + "forearm", _p + "wrist_roll": _p + "hand",
                      _p + "hip_pitch": _p + "thigh", _p + "knee": _p + "shank", _p + "ankle_roll": _p + "foot",
                      _p + "toes": _p + "toe"})


def body_name(joint):
    return BODY_NAME.get(joint, joint)


def mirror_axis(a):
    """a rotation axis (pseudo-vector) mirrored through the x-z plane"""
    return (-a[0], a[1], -a[2])


def joints():
    table = list(TRUNK)
    for side in ("left", "right"):
        rows = arm(side) + leg(side)
        for name, parent, pos, axis, rng, body, cyl in rows:
            if side == "right":
                axis = mirror_axis(axis)
            table.append((name, parent, pos, axis, rng, body, cyl))
    # the parent names of limbs use the joint's body names
    out = []
    for name, parent, pos, axis, rng, body, cyl in table:
        out.append((name, body_name(parent) if parent != "pelvis" else "pelvis", pos, axis, rng, body, cyl))
    return out


# ---------------------------------------------------------------- small vector helpers
def norm(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def rotate(v, axis, angle):
    """Rodrigues: v rotated by angle (rad) about the unit axis"""
    c, s = math.cos(angle), math.sin(angle)
    k = axis
    kxv = cross(k, v)
    kv = dot(k, v)
    return tuple(v[i] * c + kxv[i] * s + k[i] * kv * (1 - c) for i in range(3))


def add(a, b, scale=1.0):
    return tuple(x + scale * y for x, y in zip(a, b))


def num(x):
    """a number as MJCF text: short, and reproducible"""
    if abs(x) < 1e-12:
        return "0"
    return "%.10g" % x


def vec(v):
    return " ".join(num(c) for c in v)


# ---------------------------------------------------------------- cylinder geometry
def tendon_length(d, r, dq):
    """pin-to-pin length at q_mid + dq: tendon perpendicular to the lever at mid-range, d long there"""
    return math.sqrt(d * d + 2 * r * r * (1 - math.cos(dq)) + 2 * d * r * math.sin(dq))


def design_linear(bore, stroke, span):
    """lever r (m, rounded down to 0.5 mm) and pin-to-pin length d at mid-stroke for a DSNU whose
    length change over the joint span uses STROKE_USE of its stroke"""
    # pin-to-pin length of a DSNU at mid-stroke, approximately: 2 stroke + 60 mm (project's estimate)
    d = 2 * stroke + 0.06
    lo, hi = 1e-4, d * 0.9
    for _ in range(100):
        r = (lo + hi) / 2
        change = tendon_length(d, r, span / 2) - tendon_length(d, r, -span / 2)
        lo, hi = (r, hi) if change < STROKE_USE * stroke else (lo, r)
    r = math.floor(lo * 2000) / 2000
    return r, d


class Cylinder:
    pass


def design(row):
    name, parent, pos, axis, rng, body, cyl = row
    axis = norm(axis)
    q0, q1 = math.radians(rng[0]), math.radians(rng[1])
    qm, span = (q0 + q1) / 2, q1 - q0
    c = Cylinder()
    c.name, c.joint, c.kind = name, name, cyl[0]
    c.q_mid, c.span = qm, span
    if c.kind == "dsnu":
        bore, stroke, lever, toward = cyl[1], cyl[2], cyl[3], cyl[4]
        assert stroke in DSNU_STROKES and bore in DSNU_ROD, name
        assert span <= math.radians(140) + 1e-9, name + ": a linear cylinder's span is at most 140 deg"
        c.bore, c.stroke = bore, stroke
        c.area_p = math.pi * bore ** 2 / 4
        c.area_n = math.pi * (bore ** 2 - DSNU_ROD[bore] ** 2) / 4
        c.r, c.d = design_linear(bore, stroke, span)
        # lever direction at mid-range (parent frame), perpendicular to the axis
        e1 = norm(add(lever, axis, -dot(lever, axis)))
        et = norm(cross(axis, e1))
        if dot(et, toward) < 0:
            et = tuple(-x for x in et)
        # child site in the child frame: the mid-range lever rotated back to q = 0
        c.child_site = tuple(c.r * x for x in rotate(e1, axis, -qm))
        mid_point = add(pos, tuple(c.r * x for x in e1))
        c.parent_site = add(mid_point, et, c.d)      # in the parent frame
        # length over the range, exactly from the geometry
        lengths = []
        for i in range(201):
            q = q0 + span * i / 200
            child = add(pos, rotate(c.child_site, axis, q))
            lengths.append(math.dist(child, c.parent_site))
        c.l_min, c.l_max = min(lengths), max(lengths)
        c.x_mid = (lengths[0] + lengths[-1]) / 2
        assert max(abs(l - c.x_mid) for l in lengths) <= STROKE_USE * stroke / 2 + 1e-6, name
        c.dead = tube_dead_volume(bore <= 0.016)
        c.torque = c.area_p * (P_SUPPLY - P_EXHAUST) * c.r
        c.label = "Festo DSNU-%d-%d" % (round(bore * 1000), round(stroke * 1000))
    else:
        size = cyl[1]
        c.size = size
        c.stroke = span + 2 * VANE_MARGIN
        assert c.stroke <= math.radians(270), name
        c.area_p = c.area_n = DSM_TORQUE[size] / 6e5
        c.x_mid = qm
        c.dead = tube_dead_volume(size <= 12)
        c.torque = c.area_p * (P_SUPPLY - P_EXHAUST)
        c.r = None
        c.label = "Festo DSM-%d-270" % size
    c.damping = BEARING_DAMPING + (SEAL_DAMPING * c.r ** 2 if c.r else VANE_DAMPING)
    return c


# ---------------------------------------------------------------- MJCF
HEADER = """<!-- GENERATED by scripts/make_humanoid.py: do not edit by hand; change the table there and rerun.
     {what}
     Issue 15: a humanoid on a stand (pelvis welded to it, as paper 000's Kokoro robot on its stand),
     36 actuated hinges: waist 3, neck 3, each arm 8, each leg 7; {mass:.2f} kg in all.
     Units SI (m, kg, s, Pa, V); joint ranges in degrees (MJCF default), cylinder strokes in m
     (rad for the DSM rotary vanes). Sizes: Festo DSNU catalogue (round cylinders, ISO 6432) and
     Festo DSM catalogue (semi-rotary vane drives); the docstring of the script has every choice. -->
"""


def geom_xml(geom, mass, name):
    kind = geom[0]
    common = 'mass="%s" rgba="0.75 0.75 0.78 1"' % num(mass)
    if kind == "capsule":
        return '<geom name="%s" type="capsule" fromto="%s" size="%s" %s/>' % (name, vec(geom[1]), num(geom[2]), common)
    if kind == "sphere":
        return '<geom name="%s" type="sphere" size="%s" %s/>' % (name, num(geom[1]), common)
    if kind == "sphere_at":
        return '<geom name="%s" type="sphere" pos="%s" size="%s" %s/>' % (name, vec(geom[1]), num(geom[2]), common)
    if kind == "box":
        return '<geom name="%s" type="box" pos="%s" size="%s" %s/>' % (name, vec(geom[1]), vec(geom[2]), common)
    raise ValueError(kind)


def mirror_geom(geom):
    kind = geom[0]
    if kind == "capsule":
        f = geom[1]
        return ("capsule", (f[0], -f[1], f[2], f[3], -f[4], f[5]), geom[2])
    if kind in ("box", "sphere_at"):
        return (kind, (geom[1][0], -geom[1][1], geom[1][2])) + geom[2:]
    return geom


def total_mass(rows):
    return 5.0 + sum(r[5][0] for r in rows)


def worldbody(rows, cyls, with_sites):
    children = {}
    for row in rows:
        children.setdefault(row[1], []).append(row)
    out = []

    def emit(row, indent):
        name, parent, pos, axis, rng, body, cyl = row
        c = cyls[name]
        geom = body[1]
        pad = " " * indent
        bname = body_name(name)
        out.append('%s<body name="%s" pos="%s">' % (pad, bname, vec(pos)))
        comment = "%s, " % c.label + ("lever %.1f mm" % (c.r * 1000) if c.r else "on the hinge")
        out.append('%s  <joint name="%s" axis="%s" range="%s %s" damping="%s"/>  <!-- %s -->'
                   % (pad, name, vec(norm(axis)), num(rng[0]), num(rng[1]), num(c.damping), comment))
        out.append(pad + "  " + geom_xml(geom, body[0], bname))
        if with_sites and c.kind == "dsnu":
            out.append('%s  <site name="%s.rod" pos="%s" size="0.006"/>' % (pad, name, vec(c.child_site)))
        for child in children.get(bname, []):
            if with_sites and cyls[child[0]].kind == "dsnu":
                cc = cyls[child[0]]
                out.append('%s  <site name="%s.cap" pos="%s" size="0.006"/>' % (pad, child[0], vec(cc.parent_site)))
            emit(child, indent + 2)
        out.append(pad + "</body>")

    out.append('    <geom name="floor" type="plane" size="1 1 0.01" rgba="0.3 0.3 0.3 1"/>')
    out.append("    <!-- the stand: a post holding the pelvis 1 m above the floor -->")
    out.append('    <geom name="stand" type="capsule" fromto="-0.25 0 0 -0.25 0 1.0" size="0.03" rgba="0.4 0.4 0.4 1"/>')
    out.append('    <geom name="stand_arm" type="capsule" fromto="-0.25 0 1.0 -0.1 0 1.0" size="0.03" rgba="0.4 0.4 0.4 1"/>')
    out.append('    <body name="pelvis" pos="0 0 1.0">  <!-- welded to the stand: no joint -->')
    out.append('      <geom name="pelvis" type="box" size="0.1 0.14 0.07" mass="5" rgba="0.75 0.75 0.78 1"/>')
    for child in children.get("pelvis", []):
        if with_sites and cyls[child[0]].kind == "dsnu":
            out.append('      <site name="%s.cap" pos="%s" size="0.006"/>' % (child[0], vec(cyls[child[0]].parent_site)))
        emit(child, 6)
    out.append("    </body>")
    return "\n".join(out)


def custom_text(c):
    # commands=chambers: uP and uN are the ctrl of <name>.P and <name>.N (two actuators per cylinder, not four)
    keys = ["valve=proportional_per_chamber commands=chambers" + (" mount=hinge_sites" if c.kind == "dsnu" else ""),
            "stroke=%s" % num(c.stroke), "x_mid=%s" % num(c.x_mid)]
    keys.append("P.area=%s N.area=%s dead_volume=%s" % (num(c.area_p), num(c.area_n), num(c.dead)))
    keys.append("p_supply=%s p_exhaust=%s temperature=%s gas_constant=%s" %
                (num(P_SUPPLY), num(P_EXHAUST), num(TEMPERATURE), num(GAS_CONSTANT)))
    keys.append("heat_capacity_ratio=1.4 polytropic_index=1.4 compressibility=0.99 flow=thin_plate discharge_coefficient=0.72")
    keys.append("area_gain=2e-6 u_supply_seal=5.3 u_exhaust_seal=4.7 leak_area_supply=5e-8 leak_area_exhaust=5e-8 area_smoothing=1e-6")
    return "\n          ".join(keys)


def write_pneumatic(rows, cyls, mass, pid_gains):
    what = "Pneumatic humanoid: every actuated joint driven by a cylinder, one proportional valve per chamber (paper 000)."
    lines = [HEADER.format(what=what, mass=mass).rstrip("\n")]
    lines.append('<mujoco model="humanoid_pneumatic">')
    lines.append("  <!-- the pneumatic extension stores each cylinder's parameters in its actuators' user data -->")
    lines.append('  <size nuser_actuator="128"/>')
    lines.append("  <!-- 1 ms, Euler: README \"Accuracy\" (rig C: 0.013 % pressure error along a given motion at 1 ms) -->")
    lines.append('  <option timestep="%s" integrator="Euler"/>' % num(TIMESTEP))
    lines.append(VIEW)
    lines.append("  <default>")
    lines.append('    <joint type="hinge" limited="true"/>')
    lines.append("    <!-- no contacts: the robot hangs on its stand and self-collisions are off -->")
    lines.append('    <geom contype="0" conaffinity="0"/>')
    lines.append('    <site rgba="0.9 0.5 0.1 1"/>')
    lines.append("  </default>")
    lines.append("  <worldbody>")
    lines.append(worldbody(rows, cyls, True))
    lines.append("  </worldbody>")
    lines.append("  <actuator>")
    lines.append("    <!-- chambers: act = p - p_atm (Pa); P extends the cylinder (x grows). commands=chambers: the")
    lines.append("         ctrl of <name>.P and <name>.N are the voltages uP and uN of their valves (V; MPYE input")
    lines.append("         0..10 V, paper 000 used 3..7 V), so each cylinder is two actuators, not four.")
    lines.append("         A linear cylinder (mount=hinge_sites) spans from its cap pin <name>.cap on the parent")
    lines.append("         to its rod pin <name>.rod on the child; its actuators drive the hinge, and their force")
    lines.append("         is the cylinder's torque on it -->")
    for c in cyls.values():
        for role in ("P", "N"):
            lines.append('    <general name="%s.%s" joint="%s" dyntype="user" gaintype="user" ctrllimited="true" ctrlrange="0 10"/>' % (c.name, role, c.joint))
    lines.append("  </actuator>")
    lines.append("  <custom>")
    lines.append("    <!-- the PID gains this model is tuned with (models_mjcf/humanoid_pid.json, README \"The humanoid under")
    lines.append("         PID\"): pneumo rollout --controller pid uses them unless --controller-config replaces them -->")
    lines.append("    <text name=\"pneumo:controller:pid\" data=%s/>" % quoteattr(json.dumps(pid_gains)))
    for c in cyls.values():
        if c.kind == "dsnu":
            desc = "%s: A_P = pi %g^2/4, A_N with its %g mm rod; lever %.1f mm, length %.4f..%.4f m over the range" % (
                c.label, c.bore * 1000, DSNU_ROD[c.bore] * 1000, c.r * 1000, c.l_min, c.l_max)
        else:
            desc = "%s: %g N m at 6 bar -> D = %s m^3/rad; stroke = range + 10 deg" % (
                c.label, DSM_TORQUE[c.size], num(c.area_p))
        lines.append("    <!-- %s -->" % desc)
        lines.append('    <text name="pneumatic:%s" data="%s"/>' % (c.name, custom_text(c)))
    lines.append("  </custom>")
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"


def write_motors(rows, cyls, mass):
    what = ("Motor twin of humanoid_pneumatic.xml: the same bodies, joints, masses and damping, one motor per "
            "actuated joint (ctrlrange = the cylinder's mid-range torque).")
    lines = [HEADER.format(what=what, mass=mass).rstrip("\n")]
    lines.append('<mujoco model="humanoid_motors">')
    lines.append('  <option timestep="%s" integrator="Euler"/>' % num(TIMESTEP))
    lines.append(VIEW)
    lines.append("  <default>")
    lines.append('    <joint type="hinge" limited="true"/>')
    lines.append('    <geom contype="0" conaffinity="0"/>')
    lines.append('    <site rgba="0.9 0.5 0.1 1"/>')
    lines.append("  </default>")
    lines.append("  <worldbody>")
    lines.append(worldbody(rows, cyls, True))
    lines.append("  </worldbody>")
    lines.append("  <actuator>")
    for c in cyls.values():
        lines.append('    <motor name="%s" joint="%s" gear="1" ctrllimited="true" ctrlrange="%s %s"/>' % (
            c.name, c.joint, num(-c.torque), num(c.torque)))
    lines.append("  </actuator>")
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"


def main():
    rows = joints()
    cyls = {}
    for row in rows:
        cyls[row[0]] = design(row)
    mass = total_mass(rows)
    here = os.path.dirname(os.path.abspath(__file__))
    models = os.path.join(os.path.dirname(here), "models_mjcf")
    with open(os.path.join(models, "humanoid_pid.json")) as f:
        pid_gains = json.load(f)
    files = {
        "humanoid_pneumatic.xml": write_pneumatic(rows, cyls, mass, pid_gains),
        "humanoid_motors.xml": write_motors(rows, cyls, mass),
    }
    for name, text in files.items():
        with open(os.path.join(models, name), "w") as f:
            f.write(text)
    if "--table" in sys.argv:
        for c in cyls.values():
            extra = "r %5.1f mm d %.3f m L %.4f..%.4f" % (c.r * 1000, c.d, c.l_min, c.l_max) if c.r else ""
            print("%-18s %-18s span %5.1f deg stroke %.4f torque %6.2f N m damping %.3f %s" % (
                c.name, c.label, math.degrees(c.span), c.stroke, c.torque, c.damping, extra))
        print("joints %d, chambers %d, mass %.2f kg" % (len(cyls), 2 * len(cyls), mass))


if __name__ == "__main__":
    main()
