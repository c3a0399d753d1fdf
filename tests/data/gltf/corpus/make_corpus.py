#!/usr/bin/env python3
"""Writes the small glTF corpus beside this script: files shaped like Blender's glTF exports of
its everyday scenes (Y up, metres, Principled-BSDF materials as pbrMetallicRoughness, embedded
buffers), none with a light, most without a camera, as a user who never placed either exports them.

    tests/data/gltf/corpus/make_corpus.py        (rewrites the .gltf files; pure Python 3)

box.gltf             a grey cube (Blender's default material: roughness 0.5), the Khronos Box's shape
metal_sphere.gltf    a polished metal sphere (metallic 1, roughness 0): a mirror of the world
glass_on_floor.gltf  a glass sphere (transmission 1, ior 1.5) above a floor: a caustic under it
no_material.gltf     a torus without a material (glTF's default: white, metallic 1, roughness 1)
rough_ring.gltf      a brushed-metal ring (metallic 1, roughness 0.35) on a floor, a camera
still_life.gltf      a floor, a box, a metal and a glass sphere, with a camera as Blender places it
sun_sky.hdr          a world map for --env: a blue sky graded to a bright horizon, a dark ground and a
                     sun 40° high in the direction (−1, 0, −1) (Radiance RGBE, 256 × 128, uncompressed)
"""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


class Builder:
    def __init__(self):
        self.data = bytearray()
        self.views, self.accessors, self.meshes, self.nodes, self.materials = [], [], [], [], []
        self.cameras = []

    def _view(self, raw, target):
        while len(self.data) % 4:
            self.data.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw), "target": target})
        self.data += raw
        return len(self.views) - 1

    def _floats(self, rows, kind):
        flat = [c for r in rows for c in r]
        view = self._view(struct.pack("<%df" % len(flat), *flat), 34962)
        acc = {"bufferView": view, "componentType": 5126, "count": len(rows), "type": kind}
        if kind == "VEC3":
            acc["min"] = [min(r[i] for r in rows) for i in range(3)]
            acc["max"] = [max(r[i] for r in rows) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def mesh(self, name, positions, normals, indices, material=None):
        view = self._view(struct.pack("<%dI" % len(indices), *indices), 34963)
        self.accessors.append({"bufferView": view, "componentType": 5125, "count": len(indices), "type": "SCALAR"})
        index_accessor = len(self.accessors) - 1
        prim = {"attributes": {"POSITION": self._floats(positions, "VEC3"), "NORMAL": self._floats(normals, "VEC3")},
                "indices": index_accessor}
        if material is not None:
            prim["material"] = material
        self.meshes.append({"name": name, "primitives": [prim]})
        return len(self.meshes) - 1

    def material(self, name, colour, metallic, roughness, extensions=None):
        m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(colour) + [1.0],
                                                     "metallicFactor": metallic, "roughnessFactor": roughness}}
        if extensions:
            m["extensions"] = extensions
        self.materials.append(m)
        return len(self.materials) - 1

    def node(self, name, mesh=None, translation=None, rotation=None, camera=None):
        n = {"name": name}
        if mesh is not None:
            n["mesh"] = mesh
        if camera is not None:
            n["camera"] = camera
        if translation:
            n["translation"] = translation
        if rotation:
            n["rotation"] = rotation
        self.nodes.append(n)
        return len(self.nodes) - 1

    def camera(self, name, eye, target, yfov=0.6911):
        """A camera node at `eye` looking at `target` (+Y up), as Blender exports one."""
        f = [t - e for t, e in zip(target, eye)]
        fl = math.sqrt(sum(c * c for c in f))
        f = [c / fl for c in f]
        up = [0.0, 1.0, 0.0]
        r = [f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]]
        rl = math.sqrt(sum(c * c for c in r))
        r = [c / rl for c in r]
        u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
        # Columns of the camera's rotation: right, up, back (−forward); to a quaternion.
        m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
        tr = m[0][0] + m[1][1] + m[2][2]
        if tr > 0:
            s = math.sqrt(tr + 1.0) * 2
            q = [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
        elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
            s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
            q = [0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
        elif m[1][1] > m[2][2]:
            s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
            q = [(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
        else:
            s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
            q = [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s]
        self.cameras.append({"name": name, "type": "perspective",
                             "perspective": {"aspectRatio": 1.7778, "yfov": yfov, "znear": 0.1, "zfar": 100}})
        return self.node(name, camera=len(self.cameras) - 1, translation=list(eye), rotation=q)

    def write(self, name, extensions_used=()):
        doc = {"asset": {"version": "2.0", "generator": "rtpm tests/data/gltf/corpus/make_corpus.py"},
               "scene": 0, "scenes": [{"name": "Scene", "nodes": list(range(len(self.nodes)))}],
               "nodes": self.nodes, "meshes": self.meshes, "accessors": self.accessors,
               "bufferViews": self.views,
               "buffers": [{"byteLength": len(self.data),
                            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.data)).decode()}]}
        if self.materials:
            doc["materials"] = self.materials
        if self.cameras:
            doc["cameras"] = self.cameras
        if extensions_used:
            doc["extensionsUsed"] = list(extensions_used)
        with open(os.path.join(HERE, name), "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")


def cube(half):
    pos, nor, idx = [], [], []
    for axis in range(3):
        for sign in (-1, 1):
            n = [0.0, 0.0, 0.0]
            n[axis] = float(sign)
            u = [0.0, 0.0, 0.0]
            v = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v[(axis + 2) % 3] = 1.0
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append([half * (n[i] + a * u[i] + b * v[i]) for i in range(3)])
                nor.append(n)
            quad = [base, base + 1, base + 2, base, base + 2, base + 3]
            if sign < 0:
                quad = [base, base + 2, base + 1, base, base + 3, base + 2]
            idx += quad
    return pos, nor, idx


def sphere(radius, rings=32, segments=64):
    pos, nor, idx = [], [], []
    for j in range(rings + 1):
        th = math.pi * j / rings
        for i in range(segments + 1):
            ph = 2 * math.pi * i / segments
            n = [math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph)]
            pos.append([radius * c for c in n])
            nor.append(n)
    for j in range(rings):
        for i in range(segments):
            a = j * (segments + 1) + i
            b = a + segments + 1
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nor, idx


def torus(major, minor, rings=64, sides=24):
    pos, nor, idx = [], [], []
    for j in range(rings + 1):
        ph = 2 * math.pi * j / rings
        for i in range(sides + 1):
            th = 2 * math.pi * i / sides
            n = [math.cos(th) * math.cos(ph), math.sin(th), -math.cos(th) * math.sin(ph)]
            c = [major * math.cos(ph), 0.0, -major * math.sin(ph)]
            pos.append([c[k] + minor * n[k] for k in range(3)])
            nor.append(n)
    for j in range(rings):
        for i in range(sides):
            a = j * (sides + 1) + i
            b = a + sides + 1
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nor, idx


def plane(half):
    return ([[-half, 0, half], [half, 0, half], [half, 0, -half], [-half, 0, -half]],
            [[0, 1, 0]] * 4, [0, 1, 2, 0, 2, 3])


GLASS = {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}
GLASS_USED = ("KHR_materials_transmission", "KHR_materials_ior")


def rgbe(r, g, b):
    m = max(r, g, b)
    if m < 1e-32:
        return bytes(4)
    e = math.frexp(m)[1]
    scale = 256.0 / (2.0 ** e)
    return bytes([min(255, int(r * scale)), min(255, int(g * scale)), min(255, int(b * scale)), e + 128])


def sun_sky(width=256, height=128):
    """Equirectangular as rtpm reads it: u = atan2(z, x)/2π + 1/2, row 0 the zenith (Y up)."""
    sun = [-math.cos(math.radians(40)) / math.sqrt(2), math.sin(math.radians(40)), -math.cos(math.radians(40)) / math.sqrt(2)]
    sun_cos = math.cos(math.radians(2.5))  # a sun 5° across: larger than the real one, so 256 × 128 resolves it
    out = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width))
    for j in range(height):
        theta = math.pi * (j + 0.5) / height
        for i in range(width):
            phi = 2 * math.pi * ((i + 0.5) / width - 0.5)
            d = [math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)]
            if d[1] >= 0:
                t = d[1] ** 0.5
                sky = [0.9 * (1 - t) + 0.25 * t, 0.95 * (1 - t) + 0.45 * t, 1.0 * (1 - t) + 0.9 * t]
            else:
                sky = [0.12, 0.11, 0.1]
            if sum(a * b for a, b in zip(d, sun)) > sun_cos:
                sky = [2000.0, 1900.0, 1700.0]
            out += rgbe(*sky)
    with open(os.path.join(HERE, "sun_sky.hdr"), "wb") as f:
        f.write(out)


def main():
    b = Builder()
    b.node("Cube", b.mesh("Cube", *cube(1.0), b.material("Material", (0.8, 0.8, 0.8), 0.0, 0.5)))
    b.write("box.gltf")

    b = Builder()
    b.node("Sphere", b.mesh("Sphere", *sphere(1.0), b.material("Chrome", (0.9, 0.9, 0.9), 1.0, 0.0)))
    b.write("metal_sphere.gltf")

    b = Builder()
    b.node("Floor", b.mesh("Plane", *plane(3.0), b.material("Floor", (0.8, 0.8, 0.8), 0.0, 0.5)))
    b.node("Glass", b.mesh("Sphere", *sphere(0.6), b.material("Glass", (1.0, 1.0, 1.0), 0.0, 0.0, GLASS)),
           translation=[0.0, 1.2, 0.0])
    b.write("glass_on_floor.gltf", GLASS_USED)

    b = Builder()
    b.node("Torus", b.mesh("Torus", *torus(1.0, 0.35)), rotation=[0.3826834, 0.0, 0.0, 0.9238795])
    b.write("no_material.gltf")

    b = Builder()
    b.node("Floor", b.mesh("Plane", *plane(2.5), b.material("Floor", (0.7, 0.7, 0.7), 0.0, 0.5)))
    b.node("Ring", b.mesh("Torus", *torus(0.8, 0.12), b.material("Brushed", (0.95, 0.8, 0.5), 1.0, 0.35)),
           translation=[0.0, 0.12, 0.0])
    b.camera("Camera", (0.0, 2.6, 3.2), (0.0, 0.0, 0.0))
    b.write("rough_ring.gltf")

    b = Builder()
    b.node("Floor", b.mesh("Plane", *plane(4.0), b.material("Floor", (0.6, 0.55, 0.5), 0.0, 0.5)))
    b.node("Cube", b.mesh("Cube", *cube(0.5), b.material("Blue", (0.2, 0.3, 0.8), 0.0, 0.5)),
           translation=[-1.3, 0.5, -0.4])
    b.node("Chrome", b.mesh("Sphere", *sphere(0.6), b.material("Chrome", (0.9, 0.9, 0.9), 1.0, 0.0)),
           translation=[0.2, 0.6, -0.6])
    b.node("Glass", b.mesh("GlassSphere", *sphere(0.45), b.material("Glass", (1.0, 1.0, 1.0), 0.0, 0.0, GLASS)),
           translation=[1.3, 0.45, 0.5])
    b.camera("Camera", (0.0, 2.4, 5.0), (0.0, 0.4, 0.0))
    b.write("still_life.gltf", GLASS_USED)

    sun_sky()


if __name__ == "__main__":
    main()
