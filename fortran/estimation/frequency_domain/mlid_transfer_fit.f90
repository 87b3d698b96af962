!> Transfer-function fits to a frequency response: the low-order equivalent
!> systems (LOES) of handling-qualities work,
!>
!>   T(s) = (b_m s^m + ... + b_1 s + b_0) / (s^n + a_(n-1) s^(n-1) + ... + a_0) e^(-tau s),
!>
!> parameters x = [b_0 .. b_m, a_0 .. a_(n-1)] and, when fitted, tau (s).
!> The cost is the handling-qualities mismatch over the nw frequencies,
!>
!>   J = 20/nw sum_k W_k [ (G_k - Gm_k)^2 + 0.01745 (P_k - Pm_k)^2 ],
!>
!> gain G in dB and phase P in deg (the model's phase difference taken
!> within +-180 deg, so that branches of the measured unwrapped phase do
!> not count), W_k = 1 or, weighted by coherence, [1.58 (1 - exp(-gamma^2))]^2.
!> A Levenberg-Marquardt iteration on the residuals r (J = r'r) with their
!> analytic Jacobian: d ln T / d b_i = s^i / N, d ln T / d a_i = -s^i / D,
!> d ln T / d tau = -s, and d gain = 20/ln 10 Re(d ln T), d phase =
!> 180/pi Im(d ln T).  It starts from Sanathanan-Koerner iterations of
!> Levy's linear least squares (N - H D = 0 weighted by 1/|H D_prev|) in
!> s / w0, w0 the geometric mean of the frequencies, at the best of a few
!> delay starts (tf_start).
module mlid_transfer_fit
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR, MLID_ERR_NOCONV
  use mlid_linalg, only: solve
  use mlid_freq_response, only: PI, DB, DEG
  implicit none
  private
  public :: tf_size, tf_log_response, tf_residuals, tf_start, tf_fit, coherence_weight, &
            PHASE_WEIGHT

  real(wp), parameter :: PHASE_WEIGHT = 0.01745_wp     !< dB^2 per deg^2 of the mismatch
  integer, parameter :: SK_PASSES = 8
  real(wp), parameter :: MATCHED = 1.0e-24_wp  !< mismatch (dB^2) of an exactly matched response
  integer, parameter :: DELAY_STARTS = 10     !< delay starts tried (tf_start)

contains

  !> The number of parameters of numerator order m, denominator order n.
  pure integer function tf_size(m, n, delay) result(np)
    integer, intent(in) :: m, n
    logical, intent(in) :: delay
    np = m + 1 + n + merge(1, 0, delay)
  end function tf_size

  !> The customary coherence weighting [1.58 (1 - exp(-gamma^2))]^2.
  elemental real(wp) function coherence_weight(coh) result(wt)
    real(wp), intent(in) :: coh
    wt = (1.58_wp*(1.0_wp - exp(-coh)))**2
  end function coherence_weight

  !> ln T(jw) (its imaginary part the phase in rad on the principal
  !> branches of N and D) and d ln T / dx (np columns).
  pure subroutine tf_log_response(m, n, delay, x, w, lt, dlt)
    integer, intent(in) :: m, n
    logical, intent(in) :: delay
    real(wp), intent(in) :: x(:), w
    complex(wp), intent(out) :: lt, dlt(:)
    complex(wp) :: s, num, den, sp(0:max(m, n))
    integer :: i
    s = cmplx(0.0_wp, w, wp)
    sp(0) = 1.0_wp
    do i = 1, max(m, n)
      sp(i) = sp(i - 1)*s
    end do
    num = sum(x(1:m + 1)*sp(0:m))
    den = sp(n) + sum(x(m + 2:m + 1 + n)*sp(0:n - 1))
    lt = log(num) - log(den)
    dlt(1:m + 1) = sp(0:m)/num
    dlt(m + 2:m + 1 + n) = -sp(0:n - 1)/den
    if (delay) then
      lt = lt - s*x(m + n + 2)
      dlt(m + n + 2) = -s
    end if
  end subroutine tf_log_response

  !> Residuals r (2 nw: gain and phase mismatch of each frequency, scaled
  !> so that r'r = J) and their Jacobian jr (2 nw, np).
  pure subroutine tf_residuals(m, n, delay, x, w, gain, phase, wt, r, jr)
    integer, intent(in) :: m, n
    logical, intent(in) :: delay
    real(wp), intent(in) :: x(:), w(:), gain(:), phase(:), wt(:)
    real(wp), intent(out) :: r(:), jr(:, :)
    complex(wp) :: lt, dlt(size(x))
    real(wp) :: cg, cp, dp
    integer :: k
    do k = 1, size(w)
      call tf_log_response(m, n, delay, x, w(k), lt, dlt)
      cg = sqrt(20.0_wp*wt(k)/size(w))
      cp = cg*sqrt(PHASE_WEIGHT)
      dp = DEG*aimag(lt) - phase(k)
      dp = dp - 360.0_wp*anint(dp/360.0_wp)
      r(2*k - 1) = cg*(DB*real(lt) - gain(k))
      r(2*k) = cp*dp
      jr(2*k - 1, :) = cg*DB*real(dlt)
      jr(2*k, :) = cp*DEG*aimag(dlt)
    end do
  end subroutine tf_residuals

  !> Start values: Sanathanan-Koerner passes of Levy's least squares for
  !> the free coefficients (the fixed keep their values in x), the measured
  !> response advanced by the delay's start.  With the delay fitted, starts
  !> tau0 + k tmax/DELAY_STARTS (k = 0 .. DELAY_STARTS, tmax the delay of 90 deg
  !> at the highest frequency) are tried and the one of least mismatch kept:
  !> without it the coefficients would take up the delay's phase.
  subroutine tf_start(m, n, delay, tau0, w, gain, phase, wt, free, x, status, msg)
    integer, intent(in) :: m, n
    logical, intent(in) :: delay, free(:)
    real(wp), intent(in) :: tau0, w(:), gain(:), phase(:), wt(:)
    real(wp), intent(inout) :: x(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: xt(size(x)), best, cost, r(2*size(w)), jr(2*size(w), size(x)), tau
    integer :: k, kmax
    best = huge(1.0_wp)
    kmax = 0
    if (delay .and. free(size(x))) kmax = DELAY_STARTS
    xt = x
    do k = 0, kmax
      tau = tau0
      if (delay) then                    ! a fixed delay keeps the value it was given
        tau = x(size(x))
        if (free(size(x))) tau = tau0 + k*0.5_wp*PI/maxval(w)/DELAY_STARTS
        xt(size(x)) = tau
      end if
      call levy(m, n, tau, w, gain, phase, wt, free, xt, status, msg)
      if (status /= MLID_OK) return
      call tf_residuals(m, n, delay, xt, w, gain, phase, wt, r, jr)
      cost = sum(r**2)
      if (cost < best) then
        best = cost
        x = xt
      end if
    end do
  end subroutine tf_start

  !> Levy's least squares with Sanathanan-Koerner reweighting at delay tau:
  !> x's free coefficients from sum b'_i s^i - H sum a'_i s^i = H s^n over
  !> s / w0 (w0 the geometric mean of the frequencies), rows weighted by
  !> sqrt(wt) / |H D_prev|; fixed coefficients move to the right-hand side.
  subroutine levy(m, n, tau, w, gain, phase, wt, free, x, status, msg)
    integer, intent(in) :: m, n
    real(wp), intent(in) :: tau, w(:), gain(:), phase(:), wt(:)
    logical, intent(in) :: free(:)
    real(wp), intent(inout) :: x(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    complex(wp) :: h(size(w)), sg(size(w)), den(size(w)), row(m + 1 + n), rhs
    real(wp) :: a(2*size(w), m + 1 + n), b(2*size(w), 1), w0, scale(m + 1 + n)
    real(wp) :: work(64*(m + n + 2) + 2*size(w))
    integer :: k, i, pass, info, nc, nfree, nw
    integer, allocatable :: cols(:)
    nc = m + 1 + n
    nw = size(w)
    w0 = exp(sum(log(w))/nw)
    ! coefficient i of s^p scaled: b'_i = b_i w0^(p-n)
    scale = [(w0**(i - n), i=0, m), (w0**(i - n), i=0, n - 1)]
    cols = pack([(i, i=1, nc)], free(1:nc))
    nfree = size(cols)
    sg = cmplx(0.0_wp, w/w0, wp)
    h = 10.0_wp**(gain/20.0_wp)*exp(cmplx(0.0_wp, phase/DEG + w*tau, wp))
    den = 1.0_wp
    do pass = 1, SK_PASSES
      do k = 1, nw
        row(1:m + 1) = [(sg(k)**i, i=0, m)]
        row(m + 2:nc) = [(-h(k)*sg(k)**i, i=0, n - 1)]
        rhs = h(k)*sg(k)**n - sum(row*x(1:nc)*scale, mask=.not. free(1:nc))
        row = row*sqrt(wt(k))/abs(h(k)*den(k))
        rhs = rhs*sqrt(wt(k))/abs(h(k)*den(k))
        a(k, 1:nfree) = real(row(cols))
        a(nw + k, 1:nfree) = aimag(row(cols))
        b(k, 1) = real(rhs)
        b(nw + k, 1) = aimag(rhs)
      end do
      call dgels('N', 2*nw, nfree, 1, a(:, 1:nfree), 2*nw, b, 2*nw, work, size(work), info)
      if (info /= 0) then
        status = MLID_ERR_SINGULAR
        msg = 'transfer-function fit: the start''s least squares is rank deficient ' // &
              '(too few frequencies for the orders?)'
        return
      end if
      x(cols) = b(1:nfree, 1)/scale(cols)
      do k = 1, nw
        den(k) = sg(k)**n + sum([(x(m + 1 + i)*scale(m + 1 + i)*sg(k)**(i - 1), i=1, n)])
      end do
    end do
    status = MLID_OK
    msg = ''
  end subroutine levy

  !> Levenberg-Marquardt from x (in: the start; out: the fit) over the
  !> parameters marked free (the others keep their values): the
  !> mismatch J, the iterations, and the covariance of x as least squares
  !> gives it from the residuals' scatter, s^2 (Jr'Jr)^-1, s^2 = J / (2 nw - nfree)
  !> (meaningful where the mismatch is noise-like, as a measured response's;
  !> zero for the fixed parameters).
  subroutine tf_fit(m, n, delay, w, gain, phase, wt, free, max_iter, x, cost, cov, niter, &
                    status, msg)
    integer, intent(in) :: m, n, max_iter
    logical, intent(in) :: delay, free(:)
    real(wp), intent(in) :: w(:), gain(:), phase(:), wt(:)
    real(wp), intent(inout) :: x(:)
    real(wp), intent(out) :: cost, cov(:, :)
    integer, intent(out) :: niter, status
    character(len=*), intent(out) :: msg
    real(wp) :: r(2*size(w)), jr(2*size(w), size(x)), rn(2*size(w)), jn(2*size(w), size(x))
    real(wp) :: a(size(x), size(x)), g(size(x), 1), step(size(x), 1), xn(size(x)), lam, costn
    real(wp) :: eye(size(x), size(x))
    integer :: i, info
    logical :: done
    status = MLID_OK
    msg = ''
    cov = 0.0_wp
    call tf_residuals(m, n, delay, x, w, gain, phase, wt, r, jr)
    call hold_fixed(jr, free)
    cost = sum(r**2)
    lam = 1.0e-3_wp
    done = .false.
    niter = 0
    do while (niter < max_iter .and. .not. done .and. cost > 0.0_wp)
      niter = niter + 1
      a = matmul(transpose(jr), jr)
      g(:, 1) = -matmul(transpose(jr), r)
      do                                                ! raise lambda until the cost falls
        eye = a
        do i = 1, size(x)
          eye(i, i) = a(i, i)*(1.0_wp + lam) + merge(tiny(1.0_wp), 1.0_wp, free(i))
        end do
        call solve(eye, g, step, info)
        if (info == 0) then
          xn = x + step(:, 1)
          call tf_residuals(m, n, delay, xn, w, gain, phase, wt, rn, jn)
          call hold_fixed(jn, free)
          costn = sum(rn**2)
          if (costn <= cost) exit
        end if
        lam = 10.0_wp*lam
        if (lam > 1.0e16_wp) then
          done = .true.                                 ! no step lowers the cost: a minimum
          exit
        end if
      end do
      if (done) exit
      ! converged: the cost no longer falls, the step is at rounding, or the
      ! response is matched to 1e-12 dB (an exact one: the cost keeps falling)
      done = cost - costn <= 1.0e-15_wp*cost .or. costn <= MATCHED .or. &
             maxval(abs(step(:, 1))/(abs(x) + 1.0e-12_wp)) <= 1.0e-12_wp
      x = xn
      r = rn
      jr = jn
      cost = costn
      lam = max(lam/10.0_wp, 1.0e-12_wp)
    end do
    if (.not. (done .or. cost == 0.0_wp)) then
      status = MLID_ERR_NOCONV
      write (msg, '(a,i0,a)') 'transfer-function fit: no convergence in ', max_iter, ' iterations'
    end if
    call lsq_covariance(jr, free, cost, cov, info)
    if (info /= 0 .and. status == MLID_OK) then
      status = MLID_ERR_SINGULAR
      msg = 'transfer-function fit: the parameters are not identifiable from this response ' // &
            '(singular normal matrix)'
    end if
  end subroutine tf_fit

  !> Jacobian columns of the fixed parameters zeroed: they take no step.
  pure subroutine hold_fixed(jr, free)
    real(wp), intent(inout) :: jr(:, :)
    logical, intent(in) :: free(:)
    integer :: i
    do i = 1, size(free)
      if (.not. free(i)) jr(:, i) = 0.0_wp
    end do
  end subroutine hold_fixed

  !> s^2 (Jr'Jr)^-1 over the free parameters (zero rows and columns for the
  !> fixed), s^2 = cost / (rows - nfree) (0 when no degrees of freedom).
  subroutine lsq_covariance(jr, free, cost, cov, info)
    real(wp), intent(in) :: jr(:, :), cost
    logical, intent(in) :: free(:)
    real(wp), intent(out) :: cov(:, :)
    integer, intent(out) :: info
    real(wp) :: a(size(jr, 2), size(jr, 2)), eye(size(jr, 2), size(jr, 2))
    integer :: i, dof
    a = matmul(transpose(jr), jr)
    eye = 0.0_wp
    do i = 1, size(jr, 2)
      eye(i, i) = 1.0_wp
      if (.not. free(i)) a(i, i) = 1.0_wp           ! its row and column are zero
    end do
    call solve(a, eye, cov, info)
    dof = size(jr, 1) - count(free)
    cov = merge(cost/max(dof, 1), 0.0_wp, dof > 0)*cov
    do i = 1, size(free)
      if (.not. free(i)) then
        cov(i, :) = 0.0_wp
        cov(:, i) = 0.0_wp
      end if
    end do
  end subroutine lsq_covariance

end module mlid_transfer_fit
