import json, glob, os
print(json.load(open('out/any/wolf-128.json'))['normalization'])
rows=[]
for n in (128,256):
  for s in ['cylinder','wolf','face-poses','horse-collapse','horse-gallop','pcow','samba']:
    f=f'out/any/{s}-{n}.json'
    if not os.path.exists(f): continue
    d=json.load(open(f))
    fl=d['source_floor']
    pts=[]
    for p in d['points']:
      r=p['results'][0]
      pts.append("%s: %.0f kbit/s, %.2f b/v/f, surf %.4f %%, vert %.4f %%" % (p['name'].split()[0], r['kbps_30fps'], r['bits_per_input_vertex'], 100*r['surface_rms'], 100*r['source']['vertex_rms']))
    print(f"| {s} | {n} | {d['input_vertices']} | {d['frames']} | {100*fl['vertex_rms']:.4f} | {d['source_mesh_bytes']} | " + " ; ".join(pts) + " |")
