#!/usr/bin/env python3
"""A/B of one binary built with march_levers.patch: the variants of an environment variable
(ABVAR, values ABVALS) or of an `oblong` option (ABVAR=--option), interleaved per round;
prints the median trace/render time and the steps per ray of each. Usage (repo root):
    git apply experiments/traversal/results/march-levers/march_levers.patch
    cmake --build build-bench --target oblong bench_traversal
    ABVALS=0,2 python3 experiments/traversal/results/march-levers/ab.py build-bench
Scratch files go to $TMPDIR/ab."""
import json, os, subprocess, sys, statistics, tempfile
ROOT=os.path.abspath(os.path.join(os.path.dirname(__file__), '../../../..'))
B=os.path.abspath(sys.argv[1] if len(sys.argv)>1 else ROOT+'/build-bench')
TMP=os.path.join(tempfile.gettempdir(), 'ab'); os.makedirs(TMP, exist_ok=True)
var=os.environ.get('ABVAR','OBLONG_EXP_LEAFBOX'); vals=os.environ.get('ABVALS','0,1').split(',')
rounds=int(os.environ.get('ABROUNDS','3'))
scenes=os.environ.get('ABSCENES','paper/terracotta_roof,paper/diving_helmet,paper/creature,paper/alien_sphere,paper/desert_tire,asteroid').split(',')
works=os.environ.get('ABWORK','grazing,primary,path').split(',')
def rays(s):
    f=f'{TMP}/{s.replace("/","_")}.bin'
    if not os.path.exists(f):
        subprocess.run([B+'/bench_traversal','--scene',f'{ROOT}/scenes/{s}.json','--grazing','20000','--write-grazing',f],check=True,capture_output=True,cwd=ROOT)
    return f
res={}
for r in range(rounds):
  for s in scenes:
    for w in works:
      for v in vals:
        env=dict(os.environ)
        extra=[var,v] if var.startswith('--') else []
        if not extra: env[var]=v
        st=f'{TMP}/st.json'
        if w=='grazing':
            cmd=[B+'/oblong','trace',f'{ROOT}/scenes/{s}.json','--rays',rays(s),'-o',TMP+'/h_%s.bin'%v,'--threads','1','-q','--stats',st]+extra
        else:
            cmd=[B+'/oblong','render',f'{ROOT}/scenes/{s}.json','--integrator',w,'--size',os.environ.get('ABPRI','256x192') if w=='primary' else os.environ.get('ABPATH','128x96'),'-o',TMP+'/img_%s.exr'%v,'--threads','1','-q','--stats',st]+extra
        subprocess.run(cmd,check=True,env=env,cwd=ROOT)
        d=json.load(open(st)); sec=d['seconds']; t=sec.get('trace',sec.get('render'))
        rc=d.get('ray_counters',{})
        res.setdefault((s,w,v),[]).append((t,rc.get('steps_per_ray')))
      if w=='grazing' and r==0:
        import filecmp
        print(s,w,'hits same' if filecmp.cmp(TMP+'/h_%s.bin'%vals[0],TMP+'/h_%s.bin'%vals[1],shallow=False) else 'HITS DIFFER',flush=True) if len(vals)==2 else None
import math
print(f'{var}: {vals}  rounds={rounds}  load={os.getloadavg()}')
for s in scenes:
  for w in works:
    ts=[statistics.median(x[0] for x in res[(s,w,v)]) for v in vals]
    sp=[res[(s,w,v)][0][1] for v in vals]
    print(f'{s:28s} {w:8s} ' + '  '.join(f'{v}: {t*1e3:8.1f} ms {st}' for v,t,st in zip(vals,ts,sp)) + '   ratio '+' '.join(f'{ts[0]/t:.3f}' for t in ts[1:]),flush=True)
