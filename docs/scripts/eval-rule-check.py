"""Applies cgv eval's variant rule before and after 2026-12-03 (eval::keep) to the
variants listed in docs/eval/*.md and prints each rate point where they differ."""
import re,glob
SP=3.0
def old(v):
    return min(range(len(v)), key=lambda k:(v[k][1]>SP, v[k][0], k))
def new(v):
    b=min(range(len(v)), key=lambda k:(v[k][0],k))
    if v[b][1]<=SP: return b
    c=[k for k in range(len(v)) if v[k][1]<=SP and v[k][0]*v[k][1]<=v[b][0]*v[b][1]]
    return min(c, key=lambda k:(v[k][0],k)) if c else b
pct=lambda s: float(s.strip().rstrip('%').strip())
for f in sorted(glob.glob('docs/eval/*.md')):
    t=open(f).read()
    kept={}; passed={}
    sec=None
    for line in t.splitlines():
        if line.startswith('## '): sec=line
        cells=[c.strip() for c in line.strip('|').split('|')] if line.startswith('|') else None
        if not cells or cells[0] in ('rate point','---'): continue
        if sec and sec.startswith('## Quality') and cells[1].startswith('cgv') and '%' in cells[5]:
            kept.setdefault(cells[0],[]).append((pct(cells[5]), float(cells[7])))
        if sec and 'variants not kept' in sec and '%' in cells[6]:
            passed.setdefault(cells[0],[]).append((pct(cells[6]), float(cells[7])))
    for p in kept:
        v=kept[p][:1]+passed.get(p,[])
        if old(v)!=new(v): print(f, p, v, 'old', old(v), 'new', new(v))
print('checked')
