"""e = U_out/U_in of each run of sweep.sh, beside the film law (docs/validation.md, "Wet collisions").
usage: python3 measure.py RUNS/TAG RHO_S ADDED_MASS_COEFFICIENT(0)"""
import sys, csv, math
def load(path):
    return [(float(r['time']),float(r['y'])-0.125,float(r['vy'])) for r in csv.DictReader(open(path))]
def cross(rows, level, down=True, after=-1.0):
    for p,q in zip(rows,rows[1:]):
        if q[0] <= after: continue
        if (down and p[1]>=level>q[1]) or (not down and p[1]<level<=q[1]):
            s=(p[1]-level)/(p[1]-q[1]); return p[2]+s*(q[2]-p[2]), p[0]+s*(q[0]-p[0])
    return None
def measure(path, cells, D=0.25, window=0.3):
    rows=load(path); act=D/cells
    uin=-cross(rows,0.5*D)[0]; uact=-cross(rows,act)[0]
    k=min(range(len(rows)),key=lambda i:rows[i][1]); tmin=rows[k][0]
    out=cross(rows,act,down=False,after=tmin)
    uout = out[0] if out and out[1] < tmin+window else 0.0
    return uin,uact,uout,rows[k][1]/(0.5*D)
def theory(st, cells, uact, rho=8.0, ca=0.0, D=0.25, edry=0.97, rough=1e-3):
    a=D/2; mu=rho*D/(9*st); e0=rough*a; act=D/cells; K=3*math.pi*math.sqrt(2)*mu
    top=(a/act)**1.5; c0=K*((a/e0)**1.5-top)
    G=c0*e0+K*(2*a**1.5*(e0**-0.5-act**-0.5)-top*(act-e0))
    m=(rho+ca)*math.pi*a*a; dv=G/m
    return max(edry*(uact-dv)-dv,0.0) if uact>dv else 0.0
if __name__=="__main__":
    tag=sys.argv[1]; rho=float(sys.argv[2]); ca=float(sys.argv[3])
    print(f"{tag}: St | e8 e16 | theory8 theory16 | U_act8 U_act16 | Uout8 Uout16 | mingap/a")
    for st in [20,40,80,160,320,640,10000]:
        r=[];t=[]
        for c in (8,16):
            try:
                m=measure(f"{tag}/st{st}_c{c}/bodies.csv",c); r.append(m); t.append(theory(st,c,m[1],rho,ca)/m[0])
            except Exception as ex: r.append((1,1,float('nan'),float('nan'))); t.append(float('nan'))
        print(f"{st:6d} | {r[0][2]/r[0][0]:.3f} {r[1][2]/r[1][0]:.3f} | {t[0]:.3f} {t[1]:.3f} | {r[0][1]:.3f} {r[1][1]:.3f} | {r[0][2]:.3f} {r[1][2]:.3f} | {r[0][3]:.1e} {r[1][3]:.1e}")
