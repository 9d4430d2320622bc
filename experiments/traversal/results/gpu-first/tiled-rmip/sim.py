# sim.py LOG...: the 64-byte lines a canonical traversal's range queries touch, from the
# entries log-entries.patch prints, through an LRU cache of 32 KiB, 512 KiB and 4 MiB
# (fully associative), for the layers stored row after row ("row", fac9cad) and in tiles
# of w x h entries (4 x 4: 2cbefaf). Entries are 4 bytes (16-bit code pairs). Tiled
# layers are placed at 16 x their row-major offset (each layer on its own lines, tiles
# 64-byte aligned, no two layers sharing a line, as in the padded layout). Prints the
# fraction of entry reads that miss.
import sys, collections
def run(fn, layout, cap_lines):
    c=collections.OrderedDict(); miss=0; n=0
    for ln in open(fn):
        off,nx,ex,ey=map(int,ln.split())
        if layout=='row': e=off+ey*nx+ex
        else:
            tw,th=layout
            ntx=(nx+tw-1)//tw
            e=off*16+((ey//th)*ntx+ex//tw)*tw*th+(ey%th)*tw+(ex%tw)
        line=(e*4)//64
        n+=1
        if line in c: c.move_to_end(line)
        else:
            miss+=1; c[line]=1
            if len(c)>cap_lines: c.popitem(last=False)
    return miss,n
for fn in sys.argv[1:]:
    for kb in (32,512,4096):
        res=[]
        for lay in ('row',(4,4),(8,2),(2,8)):
            m,n=run(fn,lay,kb*1024//64); res.append(f"{lay}:{m/n:.3f}")
        print(fn.split('/')[-1],kb,'KB',' '.join(res))
