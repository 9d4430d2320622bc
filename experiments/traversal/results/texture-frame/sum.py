import json,sys,glob,os,math
out=sys.argv[1]
rows={}
for f in sorted(glob.glob(out+"/*.json")):
    try: json.load(open(f))
    except Exception: continue
    sc,b,_=os.path.basename(f).split('.')
    for r in json.load(open(f))['benchmarks']:
        fam,cfg=r['name'].split('/')[:2]
        rows[(sc,fam,cfg,b)]=r
print(f"{'scene':16s} {'family':9s} | {'can ms old':>9s} {'new':>7s} {'tfdm old':>8s} {'new':>7s} | {'ratio old':>9s} {'new':>6s} | steps can old/new  tfdm old/new | cells can old/new microtri? ")
geo={}
for (sc,fam,cfg,b) in sorted(rows):
    if cfg!='canonical' or b!='new': continue
    g=lambda c,bb: rows.get((sc,fam,c,bb))
    co,cn,to,tn=g('canonical','old'),g('canonical','new'),g('tfdm','old'),g('tfdm','new')
    if not all([co,cn,to,tn]): continue
    ms=lambda r: r['real_time']
    ro=ms(to)/ms(co); rn=ms(tn)/ms(cn)
    geo.setdefault(fam,[]).append((ro,rn))
    print(f"{sc:16s} {fam:9s} | {ms(co):9.1f} {ms(cn):7.1f} {ms(to):8.1f} {ms(tn):7.1f} | {ro:9.2f} {rn:6.2f} | {co['steps/ray']:6.1f} {cn['steps/ray']:6.1f}  {to['steps/ray']:6.1f} {tn['steps/ray']:6.1f} | {co['cells/ray']:6.1f} {cn['cells/ray']:6.1f} boxes {co['boxes/ray']:5.1f} {cn['boxes/ray']:5.1f} hit {co['hit%']:.2f} {cn['hit%']:.2f}")
for fam,v in geo.items():
    gm=lambda xs: math.exp(sum(map(math.log,xs))/len(xs))
    print(fam,'geomean tfdm/canonical old',round(gm([a for a,b in v]),2),'new',round(gm([b for a,b in v]),2))
