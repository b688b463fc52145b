#!/bin/bash
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export XDG_RUNTIME_DIR=$(mktemp -d)
B=.devbin/bearing-sweep
timeout 100 $B bench backend --threads 16 --sizes 1000,10000,100000,1000000 --min-time 1 --max-reps 10 > $OUT/backend-h100-par.md 2>&1
grep "^| \(cpu\|gpu\)" $OUT/backend-h100-par.md
python3 - <<'PY'
import json
d=json.load(open('sweeps/clearance-viscosity.json'))
d['axes'][0]['logspace'][2]=64; d['axes'][1]['logspace'][2]=64
d['base']['integrator']['t_end']=0.1
json.dump(d,open('/tmp/cv4096.json','w'))
f=json.load(open('sweeps/finite-film.json'))
f['name']='finite 32x32'
f['axes']=[{'path':'bearings[*].clearance','logspace':[0.0002,0.0006,32]},{'path':'bearings[*].viscosity','logspace':[0.01,0.05,32]}]
for b in f['base']['bearings']: b['model']='finite'
f['base']['integrator']['t_end']=0.01
json.dump(f,open('/tmp/fin1024.json','w'))
PY
cat > /tmp/cmp.py <<'PY'
import json,sys,glob
a=json.load(open(glob.glob(sys.argv[1]+'/*/result.json')[0])); c=json.load(open(glob.glob(sys.argv[2]+'/*/result.json')[0]))
va={v['id']:v for v in a['variants']}; vc={v['id']:v for v in c['variants']}
worst=0; where=None
def walk(x,y,p):
    global worst,where
    if isinstance(x,dict):
        for k in x:
            if k in ('t_s','stats','series','wall_time_s'): continue
            if k in y: walk(x[k],y[k],p+'.'+k)
    elif isinstance(x,list):
        for i,(u,v) in enumerate(zip(x,y)): walk(u,v,p+'[%d]'%i)
    elif isinstance(x,(int,float)) and isinstance(y,(int,float)) and not isinstance(x,bool):
        d=abs(x-y)/abs(y) if y!=0 else abs(x)
        if d>worst: worst=d; where=(p,x,y)
for i in va: walk(va[i],vc[i],'v%d'%i)
ok=lambda r: sum(1 for v in r['variants'] if v.get('status')=='ok')
print('variants', len(va), 'ok', ok(a), ok(c), 'max rel diff (values, not times)', worst, where)
PY
run() { name=$1; shift; ( /usr/bin/time -f "$name: %e s, %M KB" timeout 170 "$@" --quiet ) 2>&1 | grep -v "^plot"; }
run gpu-short $B run /tmp/cv4096.json --out /tmp/g
for n in 2 4 8; do RAYON_NUM_THREADS=$n run cpu$n-short $B run /tmp/cv4096.json --backend cpu --out /tmp/c$n; done
python3 /tmp/cmp.py /tmp/g /tmp/c8
run gpu-finite $B run /tmp/fin1024.json --out /tmp/gf
run cpu16-finite $B run /tmp/fin1024.json --backend cpu --out /tmp/cf
python3 /tmp/cmp.py /tmp/gf /tmp/cf
for d in /tmp/g /tmp/gf /tmp/cf; do python3 -c "
import json,glob,sys;r=json.load(open(glob.glob('$d/*/result.json')[0]));print('$d', r['run']['simulation_wall_s'], r['run']['simulator'].get('backend_choice',{}).get('backend'))"; done
