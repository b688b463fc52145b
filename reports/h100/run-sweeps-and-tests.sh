#!/bin/bash
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export XDG_RUNTIME_DIR=$(mktemp -d)
B=.devbin/bearing-sweep
mkdir -p /work && ln -sfn $PWD /work/main && mkdir -p target/release && cp $B target/release/bearing-sweep
for t in finite_film backend_auto; do
  BEARING_SWEEP_REQUIRE_GPU=1 timeout 120 .devbin/$t 2>&1 | grep -E "test result|FAILED|panicked" | sed "s/^/$t: /"
done | tee $OUT/tests2.txt
# A GPU-sized sweep: the paper rotor over 64 clearances x 64 viscosities (4096 variants), 0.1 s.
python3 - <<'PY'
import json
d=json.load(open('sweeps/clearance-viscosity.json'))
d['name']='H100 sweep: 64 x 64 clearance x viscosity, 0.1 s'
d['axes'][0]['logspace'][2]=64; d['axes'][1]['logspace'][2]=64
d['base']['integrator']['t_end']=0.1
json.dump(d,open('/tmp/cv4096.json','w'))
PY
( /usr/bin/time -f "auto: %e s, %M KB" timeout 200 $B run /tmp/cv4096.json --quiet --out /tmp/o-auto ) 2>&1 | tail -3
( /usr/bin/time -f "cpu: %e s, %M KB" timeout 200 $B run /tmp/cv4096.json --quiet --backend cpu --out /tmp/o-cpu ) 2>&1 | tail -3
for d in /tmp/o-auto /tmp/o-cpu; do python3 - "$d" <<'PY'
import json,sys,glob
r=json.load(open(glob.glob(sys.argv[1]+'/*/result.json')[0]))
run=r.get('run',{})
print(sys.argv[1], json.dumps(run["simulator"].get("backend_choice")), "simulation_wall_s", run.get("simulation_wall_s"), "peak_rss", run.get("peak_rss_bytes"), run["simulator"].get("device"))
PY
done
python3 - <<'PY'
import json,glob
a=json.load(open(glob.glob('/tmp/o-auto/*/result.json')[0])); c=json.load(open(glob.glob('/tmp/o-cpu/*/result.json')[0]))
va={v['id']:v for v in a['variants']}; vc={v['id']:v for v in c['variants']}
worst=0; where=None
def walk(x,y,p):
    global worst,where
    if isinstance(x,dict):
        for k in x:
            if k in ('wall_time_s','stats','series'): continue
            if k in y: walk(x[k],y[k],p+'.'+k)
    elif isinstance(x,list):
        for i,(u,v) in enumerate(zip(x,y)): walk(u,v,p+'[%d]'%i)
    elif isinstance(x,(int,float)) and isinstance(y,(int,float)) and not isinstance(x,bool):
        d=abs(x-y)/max(abs(y),1e-300) if y!=0 else abs(x)
        if d>worst: worst=d; where=(p,x,y)
for i in va: walk(va[i],vc[i],'v%d'%i)
print('variants', len(va), 'max rel diff auto(gpu) vs cpu', worst, where)
PY
cp /tmp/o-auto/*/result.json $OUT/cv4096-auto.json 2>/dev/null
timeout 250 $B finite --bench --gpu --states 2048 --reps 3 --rotor-t-end 0.1 > $OUT/finite-h100.md 2>&1; echo "finite rc $?"
cat $OUT/finite-h100.md | head -30
