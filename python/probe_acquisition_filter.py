#!/usr/bin/env python3
"""Probe (dev tool, not part of the tests): does comparing a damper model with the UTFSM tests through their
source's acquisition chain change the held-out error?

The source (DanielMaurelE/vRTHS_AMBC_MRdamper, Cap7_ModeloMR, sincronize.m) filtered force and displacement
with a causal moving average of a tenth of the drive period (`filter(ones(1,N)/N, 1, Data)`, N = 1/(10 Ts f))
and differenced the filtered displacement for the velocity. Here the reduced Spencer hysteresis (Dahl shape,
x_y, v_y) with F = (fc0 + k i) z + (c0 + c1 i) v is fitted (scipy least_squares, each test weighted equally)
leaving one amplitude/frequency group out, either to the files as they are (`none`) or through the chain
(`exact`: the window from the nominal frequency; `rule`: from the displacement's spectral peak): the motion
before the filter by Tikhonov deconvolution, the model's force averaged as the source averaged the data.

Run:  python3 -m venv probe-env && probe-env/bin/pip install numpy scipy numba
      probe-env/bin/python python/probe_acquisition_filter.py none|exact|rule [cvisc]
"""
import numpy as np, glob, os, sys, time
import scipy.sparse as sp, scipy.sparse.linalg as spl
from scipy.optimize import least_squares
from numba import njit
D=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "utfsm-mr-damper")
DETREND=bool(int(__import__("os").environ.get("DETREND","0")))
GROUPS=["10mm1Hz","25mm0p25Hz","2mm5Hz"]

def load():
    T=[]
    for p in sorted(glob.glob(D+"/*.csv")):
        L=[l for l in open(p) if l.strip() and not l.startswith("#")]
        cols=L[0].strip().split(","); a=np.loadtxt(L[1:],delimiter=",")
        c={n:a[:,cols.index(n)] for n in ("t_s","x_m","v_m_s","i_a","f_n")}
        name=os.path.basename(p)[:-4]; g=name.split("_")[0]
        dt=np.median(np.diff(c["t_s"]))
        X=np.abs(np.fft.rfft(c["x_m"]-c["x_m"].mean())); fr=np.fft.rfftfreq(len(c["x_m"]),dt)
        f0=fr[1+np.argmax(X[1:])]
        T.append(dict(name=name,group=g,dt=dt,f0=f0,x=c["x_m"],v=c["v_m_s"],i=c["i_a"],f=c["f_n"]))
    return T

def deconv(xm,N,dt,f0,c=1e-6):
    n=len(xm); m=n+N-1
    rows=np.repeat(np.arange(n),N); colsi=(np.arange(n)[:,None]+np.arange(N)[None,:]).ravel()
    A=sp.csr_matrix((np.full(n*N,1.0/N),(rows,colsi)),shape=(n,m))
    D2=sp.diags([np.ones(m-2),-2*np.ones(m-2),np.ones(m-2)],[0,1,2],shape=(m-2,m))
    mu=c/(2*np.pi*f0*dt)**4
    u=spl.spsolve((A.T@A+mu*(D2.T@D2)).tocsc(),A.T@xm)
    return u, np.sqrt(np.mean((A@u-xm)**2))

@njit(cache=True)
def spencer(x,dt,xy,vy,z0):
    n=len(x); z=np.empty(n); zk=z0
    for k in range(n):
        z[k]=zk
        if k==n-1: break
        v=(x[k+1]-x[k])/dt
        w0=v-vy*zk; s=np.sign(w0)
        if s==0: continue
        sv=s*v
        r=v/vy if (sv<vy and vy>0) else s
        e0=abs(r-zk); cd=abs(v-s*vy)/xy; cc=vy/xy
        E=np.exp(-cd*dt)
        frac=-np.expm1(-cd*dt)/cd if cd*dt>1e-12 else dt
        e=e0*E/(1+cc*e0*frac)
        zk=min(1.0,max(-1.0,r-s*e))
    return z

def prep(T,obs):
    for t in T:
        if obs:
            f0n={"10mm1Hz":1.0,"25mm0p25Hz":0.25,"2mm5Hz":5.0}[t["group"]]
            N=int(round(1/(10*t["dt"]*(t["f0"] if obs=="rule" else f0n))))
            t["N"]=N
            u,err=deconv(t["x"],N,t["dt"],t["f0"])
            t["xs"]=u; t["vs"]=np.gradient(u,t["dt"]); t["rec_err"]=err
        else:
            t["N"]=1; t["xs"]=t["x"]; t["vs"]=t["v"]
    return T

def predict(t,p,cvisc):
    fc0,k,c0,c1,xy,vy=p
    i=abs(t["i"][0])
    z=spencer(t["xs"],t["dt"],xy,vy,np.sign(t["vs"][0]))
    F=(fc0+k*i)*z+(c0+c1*i*cvisc)*t["vs"]
    N=t["N"]
    if N>1:
        cs=np.concatenate([[0],np.cumsum(F)])
        F=(cs[N:]-cs[:-N])/N   # causal MA, length n
    if DETREND: F=F-F.mean()
    return F

def fit(T,sel,cvisc):
    tr=[t for t in T if sel(t)]
    v=np.concatenate([t["v"] for t in tr]); i=np.concatenate([np.abs(t["i"]) for t in tr]); f=np.concatenate([t["f"] for t in tr])
    A=np.stack([np.sign(v),np.sign(v)*i,v],1); c=np.maximum(np.linalg.lstsq(A,f,rcond=None)[0],1.0)
    xm=max(abs(t["x"]).max() for t in tr); vm=max(abs(t["v"]).max() for t in tr)
    p0=np.array([c[0],c[1],c[2],0.5*c[2],0.02*xm,0.1*vm]); sc=p0.copy(); sc[3]=c[2]
    lo=np.array([0,0,0,0,1e-7,0]); hi=np.array([np.inf]*4+[0.01,1.0])
    w=[1/np.sqrt(len(t["f"])) for t in tr]
    def res(u):
        p=u*sc
        return np.concatenate([(predict(t,p,cvisc)-t["f"])*wk for t,wk in zip(tr,w)])
    best=None
    for s in (1.0,0.3,3.0):
        u0=p0/sc; u0[4:]*=s
        if not cvisc: u0[3]=0
        r=least_squares(res,u0,bounds=(lo/sc,hi/sc),x_scale="jac",max_nfev=300)
        if best is None or r.cost<best.cost: best=r
    return best.x*sc

def nrmse(T,p,cvisc):
    e=np.concatenate([predict(t,p,cvisc)-t["f"] for t in T]); f=np.concatenate([t["f"] for t in T])
    return np.sqrt(np.mean(e**2)/np.mean(f**2))

if __name__=="__main__":
    obs=sys.argv[1] if len(sys.argv)>1 else "none"
    cvisc=len(sys.argv)>2 and sys.argv[2]=="cvisc"
    T=load(); T=prep(T,None if obs=="none" else obs)
    if obs!="none":
        for t in T: print(f"  {t['name']}: f0={t['f0']:.3f} N={t['N']} deconv rms err {t['rec_err']*1e6:.3f} um", file=sys.stderr)
    held=[];allh=[]
    for g in GROUPS:
        p=fit(T,lambda t:t["group"]!=g,cvisc)
        te=[t for t in T if t["group"]==g]
        held.append(nrmse(te,p,cvisc)); allh+=te
        print(f"  fold {g}: {held[-1]:.4f}  p={np.array2string(p,precision=4)}",file=sys.stderr)
    # pooled held-out (per-sample)
    num=0;den=0
    for g in GROUPS:
        p=fit(T,lambda t:t["group"]!=g,cvisc)
        for t in T:
            if t["group"]==g:
                num+=np.sum((predict(t,p,cvisc)-t["f"])**2); den+=np.sum(t["f"]**2)
    pa=fit(T,lambda t:True,cvisc)
    print(f"obs={obs} cvisc={cvisc}: held out {' / '.join(f'{h:.4f}' for h in held)}  pooled {np.sqrt(num/den):.4f}  fitted-on-all {nrmse(T,pa,cvisc):.4f}")
