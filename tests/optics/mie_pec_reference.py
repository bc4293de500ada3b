# mie_pec_reference.py — exact Mie series of a perfectly conducting sphere in 60-digit decimal
# arithmetic (independent check of MIEV0 case 1, see test_optics_mie.c). Run: python3 <file>
from decimal import Decimal as D, getcontext
getcontext().prec = 60
def sincos(x):
    s=D(0); c=D(0); t=D(1); k=0
    # cos
    term=D(1); c=D(0); n=0
    while True:
        c+=term; n+=2; term=-term*x*x/(n*(n-1))
        if abs(term)<D(10)**-70: break
    term=x; s=D(0); n=1
    while True:
        s+=term; n+=2; term=-term*x*x/(n*(n-1))
        if abs(term)<D(10)**-70: break
    return s,c
def cdiv(a,b):
    den=b[0]*b[0]+b[1]*b[1]
    return ((a[0]*b[0]+a[1]*b[1])/den,(a[1]*b[0]-a[0]*b[1])/den)
def pec(x, N=12):
    x=D(x); s,c=sincos(x)
    psim1, psi0 = c, s
    chim1, chi0 = -s, c
    qsca=D(0); qext=D(0); sg=D(0); ap=bp=None
    for n in range(1,N+1):
        psi=(2*n-1)/x*psi0-psim1; chi=(2*n-1)/x*chi0-chim1
        xi=(psi,-chi); xi0=(psi0,-chi0)
        t=n/x
        a=cdiv((t*psi-psi0,D(0)),(t*xi[0]-xi0[0],t*xi[1]-xi0[1]))
        b=cdiv((psi,D(0)),xi)
        w=2*n+1
        qsca+=w*(a[0]**2+a[1]**2+b[0]**2+b[1]**2); qext+=w*(a[0]+b[0])
        sg+=D(w)/(n*(n+1))*(a[0]*b[0]+a[1]*b[1])
        if ap: sg+=D((n-1)*(n+1))/n*(ap[0]*a[0]+ap[1]*a[1]+bp[0]*b[0]+bp[1]*b[1])
        ap,bp=a,b
        psim1,psi0=psi0,psi; chim1,chi0=chi0,chi
    x2=x*x
    return 2*qext/x2, 2*qsca/x2, 4*sg/x2/(2*qsca/x2)
for x in ['0.099','0.101']:
    print(x, pec(x))
