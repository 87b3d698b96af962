!> The steady-state covariance of the Kalman filter's one-step prediction,
!> and its partials.
!>
!> The prediction covariance P = P(j|j-1) of a time-invariant filter with
!> transition A, output matrix C, state noise Q (nx x nx), measurement noise
!> R and their cross-covariance G = E{w v'} (nx x ny, as it reaches the
!> state) tends to the solution of the discrete algebraic Riccati equation
!>
!>     P = A P A' + Q - (A P C' + G) (C P C' + R)^-1 (A P C' + G)'.
!>
!> dare_solve finds it by the structured doubling algorithm (Chu, Fan, Lin
!> and Wang, 2004): after the cross term is taken out (A - G R^-1 C and
!> Q - G R^-1 G'), each doubling step doubles the horizon of the Riccati
!> recursion, so some 30 steps stand for 10^9 of them, however slowly the
!> recursion itself would settle (small R, slow modes).  The solution's
!> residual is checked.
!>
!> A partial dP of P follows from the same equation differentiated: with the
!> predictor gain Kp = (A P C' + G) B^-1 and the closed loop Ac = A - Kp C,
!>
!>     dP = Ac dP Ac' + E,
!>     E = Y + Y' + dQ - dG Kp' - Kp dG' + Kp dR Kp',  Y = dA P Ac' - Ac P dC' Kp',
!>
!> a Stein (discrete Lyapunov) equation, solved for all partials with one
!> factorisation of I - Ac (x) Ac (stein_solve).
!>
!> The continuous algebraic Riccati equation of the textbook's filter error
!> (Jategaonkar ch. 5, eq. 5.15 with R dt as the measurement density),
!>
!>     A P + P A' + Q - P G P = 0,   G = C' (R dt)^-1 C,
!>
!> care_solve finds its stabilising solution (A - P G stable) from the sign
!> of the Hamiltonian [A', -G; -Q, -A] (scaled Newton iteration), whose
!> stable invariant subspace is the range of [I; P], polished by Newton
!> (Kleinman) steps, each a continuous Lyapunov equation (lyap_solve); its
!> partials solve the same Lyapunov equation with the closed loop A - P G.
module mlid_riccati
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_NOCONV
  use mlid_linalg, only: solve, chol_inverse
  use mlid_text, only: es_text
  implicit none
  private
  public :: dare_solve, stein_solve, riccati_residual, care_solve, lyap_solve

  integer, parameter :: MAX_DOUBLINGS = 100
  !> Sign iterations at most (they converge quadratically: some 10 suffice),
  !> and the Newton steps that polish the solution.
  integer, parameter :: MAX_SIGN = 100, POLISH = 2
  !> A solution whose residual exceeds this fraction of max(|P|, |Q|) is refused.
  real(wp), parameter :: RESIDUAL_TOL = 1.0e-6_wp

contains

  !> P solving the Riccati equation above; status MLID_ERR_NOCONV with a
  !> message when the doubling does not settle or the residual is too large
  !> (no stabilising solution: a mode neither damped nor observed), and
  !> MLID_ERR_SINGULAR when R is not positive definite.
  subroutine dare_solve(a, c, q, r, g, p, status, msg)
    real(wp), intent(in) :: a(:, :), c(:, :), q(:, :), r(:, :), g(:, :)
    real(wp), intent(out) :: p(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: rinv(size(r, 1), size(r, 1)), logdet, grinv(size(a, 1), size(r, 1))
    real(wp), dimension(size(a, 1), size(a, 1)) :: ak, gk, hk, w, x1, x2, hnew
    integer :: it, ierr, i, n
    real(wp) :: res

    n = size(a, 1)
    p = 0.0_wp
    call chol_inverse(r, rinv, logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'steady-state Kalman filter: the measurement-noise covariance R is not positive definite'
      return
    end if
    ! the dual (control) form X = A~' X A~ - ... with A~ = (A - G R^-1 C)'
    grinv = matmul(g, rinv)
    ak = transpose(a - matmul(grinv, c))
    gk = matmul(transpose(c), matmul(rinv, c))
    hk = q - matmul(grinv, transpose(g))
    hk = 0.5_wp*(hk + transpose(hk))
    do it = 1, MAX_DOUBLINGS
      w = matmul(gk, hk)
      do i = 1, n
        w(i, i) = w(i, i) + 1.0_wp
      end do
      call solve(w, ak, x1, ierr)                     ! (I + G H)^-1 A
      if (ierr == 0) call solve(w, gk, x2, ierr)      ! (I + G H)^-1 G
      if (ierr /= 0) exit
      hnew = hk + matmul(transpose(ak), matmul(hk, x1))
      gk = gk + matmul(ak, matmul(x2, transpose(ak)))
      ak = matmul(ak, x1)
      hnew = 0.5_wp*(hnew + transpose(hnew))
      gk = 0.5_wp*(gk + transpose(gk))
      if (.not. all(ieee_is_finite(hnew))) exit
      if (maxval(abs(hnew - hk)) <= 1.0e-15_wp*maxval(abs(hnew))) then
        hk = hnew
        exit
      end if
      hk = hnew
    end do
    p = hk
    res = riccati_residual(a, c, q, r, g, p)
    if (ierr /= 0 .or. it > MAX_DOUBLINGS .or. .not. res <= RESIDUAL_TOL) then
      status = MLID_ERR_NOCONV
      msg = 'steady-state Kalman filter: no stabilising solution of the Riccati equation '// &
            '(relative residual '//es_text(res, 9, 2)//'): a mode is neither damped nor seen '// &
            'in the outputs, or R is too small'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine dare_solve

  !> |P - (A P A' + Q - (A P C' + G) B^-1 (A P C' + G)')| relative to
  !> max(|P|, |Q|), largest entries; huge when B is not positive definite.
  real(wp) function riccati_residual(a, c, q, r, g, p) result(res)
    real(wp), intent(in) :: a(:, :), c(:, :), q(:, :), r(:, :), g(:, :), p(:, :)
    real(wp) :: b(size(r, 1), size(r, 1)), binv(size(r, 1), size(r, 1)), logdet
    real(wp) :: m(size(a, 1), size(r, 1)), e(size(a, 1), size(a, 1))
    integer :: ierr
    res = huge(1.0_wp)
    if (.not. all(ieee_is_finite(p))) return
    b = matmul(c, matmul(p, transpose(c))) + r
    call chol_inverse(0.5_wp*(b + transpose(b)), binv, logdet, ierr)
    if (ierr /= 0) return
    m = matmul(a, matmul(p, transpose(c))) + g
    e = p - matmul(a, matmul(p, transpose(a))) - q + matmul(m, matmul(binv, transpose(m)))
    res = maxval(abs(e))/max(maxval(abs(p)), maxval(abs(q)), tiny(1.0_wp))
  end function riccati_residual

  !> x(:, :, k) = ac x(:, :, k) ac' + e(:, :, k) for every k, by one LU
  !> factorisation of I - ac (x) ac (n^2 unknowns: the filters here have a
  !> handful of states).  info > 0: ac has eigenvalues whose products are 1
  !> (the closed loop is not stable).
  subroutine stein_solve(ac, e, x, info)
    real(wp), intent(in) :: ac(:, :), e(:, :, :)
    real(wp), intent(out) :: x(:, :, :)
    integer, intent(out) :: info
    real(wp) :: k(size(ac, 1)**2, size(ac, 1)**2), rhs(size(ac, 1)**2, size(e, 3))
    real(wp) :: sol(size(ac, 1)**2, size(e, 3))
    integer :: n, i, j, p, q

    n = size(ac, 1)
    info = 0
    if (size(e, 3) == 0) return
    ! vec(A X A') = (A (x) A) vec(X), column-major vec: row (i,j) -> i + (j-1) n
    do q = 1, n
      do p = 1, n
        do j = 1, n
          do i = 1, n
            k(i + (j - 1)*n, p + (q - 1)*n) = -ac(i, p)*ac(j, q)
          end do
        end do
      end do
    end do
    do i = 1, n*n
      k(i, i) = k(i, i) + 1.0_wp
    end do
    rhs = reshape(e, [n*n, size(e, 3)])
    call solve(k, rhs, sol, info)
    if (info /= 0) return
    x = reshape(sol, shape(x))
    do i = 1, size(x, 3)
      x(:, :, i) = 0.5_wp*(x(:, :, i) + transpose(x(:, :, i)))
    end do
  end subroutine stein_solve

  !> P solving A P + P A' + Q - P G P = 0 (all n x n, Q and G symmetric
  !> positive semi-definite) with A - P G stable.  status MLID_ERR_NOCONV
  !> with a message when there is none (a mode neither damped nor seen) or
  !> the residual is too large.
  subroutine care_solve(a, g, q, p, status, msg)
    real(wp), intent(in) :: a(:, :), g(:, :), q(:, :)
    real(wp), intent(out) :: p(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: z(2*size(a, 1), 2*size(a, 1)), zi(2*size(a, 1), 2*size(a, 1))
    real(wp) :: eye2(2*size(a, 1), 2*size(a, 1)), mm(2*size(a, 1), size(a, 1))
    real(wp) :: nn(2*size(a, 1), size(a, 1)), x(size(a, 1), size(a, 1), 1)
    real(wp) :: e(size(a, 1), size(a, 1), 1), ac(size(a, 1), size(a, 1)), c, res
    integer :: n, i, it, ierr

    n = size(a, 1)
    status = MLID_ERR_NOCONV
    msg = 'textbook filter gain: no stabilising solution of the continuous Riccati equation '// &
          '(a mode is neither damped nor seen in the outputs)'
    p = 0.0_wp
    eye2 = 0.0_wp
    do i = 1, 2*n
      eye2(i, i) = 1.0_wp
    end do
    z(1:n, 1:n) = transpose(a)
    z(1:n, n + 1:) = -g
    z(n + 1:, 1:n) = -q
    z(n + 1:, n + 1:) = -a
    do it = 1, MAX_SIGN          ! Z <- (c Z + Z^-1 / c) / 2, c = sqrt(|Z^-1| / |Z|)
      call solve(z, eye2, zi, ierr)
      if (ierr /= 0 .or. .not. all(ieee_is_finite(zi))) return
      c = sqrt(norm2(zi)/norm2(z))
      zi = 0.5_wp*(c*z + zi/c)
      if (norm2(zi - z) <= 1.0e-13_wp*norm2(zi)) exit
      z = zi
    end do
    z = zi
    ! (W + I) [I; P] = 0: [W12; W22 + I] P = -[W11 + I; W21], by least squares
    mm = z(:, n + 1:) + eye2(:, n + 1:)
    nn = -(z(:, 1:n) + eye2(:, 1:n))
    call solve(matmul(transpose(mm), mm), matmul(transpose(mm), nn), p, ierr)
    if (ierr /= 0) return
    p = 0.5_wp*(p + transpose(p))
    do it = 1, POLISH            ! Newton: (A - P G) P+ + P+ (A - P G)' + Q + P G P = 0
      ac = a - matmul(p, g)
      e(:, :, 1) = q + matmul(p, matmul(g, p))
      call lyap_solve(ac, e, x, ierr)
      if (ierr /= 0) return
      p = x(:, :, 1)
    end do
    res = maxval(abs(matmul(a, p) + matmul(p, transpose(a)) + q - matmul(p, matmul(g, p))))/ &
          max(maxval(abs(q)), maxval(abs(matmul(a, p))), tiny(1.0_wp))
    if (.not. (res <= RESIDUAL_TOL .and. all(ieee_is_finite(p)))) return
    status = MLID_OK
    msg = ''
  end subroutine care_solve

  !> x(:, :, k) solving ac x + x ac' + e(:, :, k) = 0 for every k, by one LU
  !> factorisation of I (x) ac + ac (x) I.  info > 0: two eigenvalues of ac
  !> sum to zero (no unique solution).
  subroutine lyap_solve(ac, e, x, info)
    real(wp), intent(in) :: ac(:, :), e(:, :, :)
    real(wp), intent(out) :: x(:, :, :)
    integer, intent(out) :: info
    real(wp) :: k(size(ac, 1)**2, size(ac, 1)**2), rhs(size(ac, 1)**2, size(e, 3))
    real(wp) :: sol(size(ac, 1)**2, size(e, 3))
    integer :: n, i, j, p

    n = size(ac, 1)
    info = 0
    if (size(e, 3) == 0) return
    k = 0.0_wp               ! column-major vec: row (i,j) -> i + (j-1) n
    do j = 1, n
      do p = 1, n
        do i = 1, n
          k(i + (j - 1)*n, p + (j - 1)*n) = k(i + (j - 1)*n, p + (j - 1)*n) + ac(i, p)
          k(i + (j - 1)*n, i + (p - 1)*n) = k(i + (j - 1)*n, i + (p - 1)*n) + ac(j, p)
        end do
      end do
    end do
    rhs = -reshape(e, [n*n, size(e, 3)])
    call solve(k, rhs, sol, info)
    if (info /= 0) return
    x = reshape(sol, shape(x))
    do i = 1, size(x, 3)
      x(:, :, i) = 0.5_wp*(x(:, :, i) + transpose(x(:, :, i)))
    end do
  end subroutine lyap_solve

end module mlid_riccati
