"""Bits per input vertex per frame at 1 / 0.5 / 0.2 / 0.1 / 0.05 % vertex RMS:
ours (whole files, the mesh line included) against the better peer.
Usage: levels.py DIR SEQ... (DIR holds SEQ-peers.json and SEQ-vertices.json)."""
import json, math, sys
levels=[1,0.5,0.2,0.1,0.05]
def interp(pts, lvl):
    # pts: (error %, bits); fewest bits reaching lvl, log-log between neighbours; flat below the coarsest
    pts=sorted(pts)
    best=None
    for (e1,b1),(e2,b2) in zip(pts,pts[1:]):
        if e1<=lvl<=e2 and e2>e1:
            t=(math.log(lvl)-math.log(e1))/(math.log(e2)-math.log(e1))
            b=math.exp(math.log(b1)+t*(math.log(b2)-math.log(b1)))
            best=b if best is None else min(best,b)
    for e,b in pts:
        if e<=lvl: best=b if best is None else min(best,b)
    return best
d=sys.argv[1]
for s in sys.argv[2:]:
    peers=json.load(open(f'{d}/{s}-peers.json'))
    ev=json.load(open(f'{d}/{s}-vertices.json'))
    n=ev['frames']*ev['input_vertices']
    ours=[]
    for p in ev['points']:
        for c in p['results']:
            b=(c['bytes']+(c.get('own_mesh_bytes') or 0))*8/n
            ours.append((c['source']['vertex_rms']*100, b))
    row=[]
    for l in levels:
        pv=[interp([(p['vertex_rms']*100,p['bits_per_input_vertex']) for p in cv['points']], l) for cv in peers['curves']]
        pv=[x for x in pv if x is not None]
        o=interp(ours,l)
        row.append(f"{o:.2f} vs {min(pv):.2f}" if o and pv else f"{o} vs {pv}")
    print(s, ' | '.join(row))
    print('  ours:', ', '.join(f"{b:.2f}: {e:.4f} %" for e,b in sorted(ours, key=lambda x:x[1])))
