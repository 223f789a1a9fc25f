#!/usr/bin/env python3
# Configurations for docs/textures.md: textured line lights (k stripes along a segment of length 1
# at distance d), in the eval input format. Usage: scripts/texture-scan-configs.py OUT.jsonl
import json, math, random, sys
random.seed(25)
out = open(sys.argv[1], 'w')
for d in [0.1, 0.3, 1.0, 3.0, 10.0]:
    for k in [1, 2, 4, 8, 16]:
        for i in range(20):
            # segment of length 1, its closest point to the origin at distance d, elevation 20-80 deg
            el = math.radians(random.uniform(20, 80)); az = random.uniform(0, 2 * math.pi)
            foot = [d * math.cos(el) * math.cos(az), d * math.cos(el) * math.sin(az), d * math.sin(el)]
            # a tangent perpendicular to the foot, random about it
            h = [-math.sin(az), math.cos(az), 0.0]
            v = [-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)]
            a = random.uniform(0, 2 * math.pi)
            t = [math.cos(a) * h[j] + math.sin(a) * v[j] for j in range(3)]
            c = random.uniform(-0.5, 0.5)  # where the foot falls along the segment
            p1 = [foot[j] + (c - 0.5) * t[j] for j in range(3)]
            p2 = [foot[j] + (c + 0.5) * t[j] for j in range(3)]
            if p1[2] < 0.02 or p2[2] < 0.02:
                continue
            nu = 2 * k
            texels = [0.2 if (q % 2 == 0) else 1.0 for q in range(nu)]
            out.write(json.dumps({"id": f"d{d}_k{k}_{i}", "p1": p1, "p2": p2, "material": {"kind": "diffuse"},
                                  "texture": {"kind": "cylindrical", "size": [nu, 1], "texels": texels}}) + "\n")
