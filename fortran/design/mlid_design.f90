!> Optimal input design for linear models (report §VII).
!>
!> The unknowns theta_i (elements of F, G or H, weights w_i) and the state
!> make the augmented system of eqs 7.15-7.19,
!>
!>   x_A = [x; sqrt(w_1) dx/dtheta_1; ...],  xdot_A = F_A x_A + G_A u,
!>
!> whose outputs sqrt(w_i) dy/dtheta_i = H_A,i x_A give the weighted trace
!> tr(W M) = int x_A' Q_A x_A dt, Q_A = sum_i H_A,i' R^-1 H_A,i (eq. 7.20).
!> Under the energy constraint int u'u dt = E the best input is the
!> eigenfunction of the largest eigenvalue mu of A* Q_A A (eq. 7.39), and
!> max tr(WM) = mu E.  Three solvers, cross-checked in the tests:
!>
!>   operator_mu    the operator on a grid of piecewise-constant input cells,
!>                  exact per cell (Van Loan), its largest eigenpair from
!>                  LAPACK; two grids and Richardson extrapolation (eq. 7.39)
!>   riccati_length the Riccati equation 7.31 from P(0) = 0 forward to its
!>                  first blow-up, the conjugate point T of mu (§7.2.2, §7.7)
!>   transition_length  det Phi_ll(T; mu) = 0 of the Hamiltonian transition
!>                  matrix (eqs 7.25-7.29), lambda(0) from the smallest
!>                  eigenvector of Phi_ll' Phi_ll
!>
!> R is the spectral density of the continuous measurement noise (eq. 7.11).
module mlid_design
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_positive_inf
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR, MLID_ERR_NOCONV, &
                        MLID_ERR_INTERNAL
  use mlid_linalg, only: expm, sym_eig, solve, chol_inverse
  use mlid_interrupt, only: check_interrupt, interrupt_requested, POLL_MASK
  implicit none
  private
  public :: design_t, design_create, operator_mu, riccati_length, transition_length, &
            costate_input, input_information, mu_for_length, amplitude_limited_input, &
            design_state_penalty, input_response, energy_input, operator_input, equalised_input, &
            information_summary, servo_model, simpson_weights

  type :: design_t
    integer :: nx = 0, nu = 0, ny = 0, m = 0, na = 0
    real(wp), allocatable :: fa(:, :), ga(:, :), qa(:, :)
    !> ha(:, :, i): sqrt(w_i) dy/dtheta_i = ha_i x_A; rinv = R^-1; w the weights
    real(wp), allocatable :: ha(:, :, :), rinv(:, :), w(:)
  end type design_t

  !> Input cells times inputs at the most for the operator solver: its
  !> matrices are (2 cells inputs)^2 (about 256 MB at the limit).
  integer, parameter, public :: MAX_CELLS = 2000
  !> The secant of eq. 7.89 starts within this share of the operator's mu: a
  !> wider bracket has no conjugate point once it passes the supremum of
  !> mu(T) (the C-8 design at T = 8 s)
  real(wp), parameter, public :: RICCATI_BRACKET = 1.0e-3_wp

contains

  !> The augmented system for unknowns given by block (1 F, 2 G, 3 H), row
  !> and column, and weights w (> 0).  With process noise (gq = Gamma Q
  !> Gamma', §7.5) the sensitivities are those of the steady-state Kalman
  !> filter, driven by F - K H (eq. 7.84), the gain K = Sigma H' R^-1 held.
  subroutine design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), w(:)
    integer, intent(in) :: ukind(:), urow(:), ucol(:)
    type(design_t), intent(out) :: d
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(in), optional :: gq(:, :)
    real(wp) :: fs(size(f, 1), size(f, 1)), k(size(f, 1), size(h, 1))
    integer :: nx, nu, ny, m, i, o
    real(wp) :: logdet, sw

    status = MLID_ERR_INPUT
    nx = size(f, 1)
    nu = size(g, 2)
    ny = size(h, 1)
    m = size(ukind)
    if (m < 1) then
      msg = 'input design needs at least one unknown'
      return
    end if
    if (nu < 1) then
      msg = 'input design needs at least one input'
      return
    end if
    if (any(.not. ieee_is_finite(w)) .or. any(w <= 0.0_wp)) then
      msg = 'weights must be finite and > 0'
      return
    end if
    if (.not. (all(ieee_is_finite(f)) .and. all(ieee_is_finite(g)) .and. &
               all(ieee_is_finite(h)) .and. all(ieee_is_finite(r)))) then
      msg = 'F, G, H and R must be finite'
      return
    end if
    do i = 1, m
      select case (ukind(i))
      case (1)
        if (urow(i) < 1 .or. urow(i) > nx .or. ucol(i) < 1 .or. ucol(i) > nx) exit
      case (2)
        if (urow(i) < 1 .or. urow(i) > nx .or. ucol(i) < 1 .or. ucol(i) > nu) exit
      case (3)
        if (urow(i) < 1 .or. urow(i) > ny .or. ucol(i) < 1 .or. ucol(i) > nx) exit
      case default
        exit
      end select
    end do
    if (i <= m) then
      write (msg, '(a,i0,a)') 'unknown ', i, ' is not an element of F, G or H'
      return
    end if
    d%nx = nx
    d%nu = nu
    d%ny = ny
    d%m = m
    d%na = (m + 1)*nx
    d%w = w
    allocate (d%fa(d%na, d%na), d%ga(d%na, nu), d%ha(ny, d%na, m), d%rinv(ny, ny), &
              d%qa(d%na, d%na))
    call chol_inverse(r, d%rinv, logdet, i)
    if (i /= 0) then
      status = MLID_ERR_INPUT
      msg = 'noise spectral density R must be positive definite'
      return
    end if
    fs = f
    if (present(gq)) then
      if (any(gq /= 0.0_wp)) then
        call steady_gain(f, h, d%rinv, gq, k, status, msg)
        if (status /= MLID_OK) return
        status = MLID_ERR_INPUT
        fs = f - matmul(k, h)
      end if
    end if
    d%fa = 0.0_wp
    d%ga = 0.0_wp
    d%ha = 0.0_wp
    d%fa(1:nx, 1:nx) = f
    d%ga(1:nx, :) = g
    do i = 1, m
      o = i*nx
      sw = sqrt(w(i))
      d%fa(o + 1:o + nx, o + 1:o + nx) = fs
      d%ha(:, o + 1:o + nx, i) = h
      select case (ukind(i))           ! eq. 7.15: the derivative of F, G or H drives s_i
      case (1)
        d%fa(o + urow(i), ucol(i)) = sw
      case (2)
        d%ga(o + urow(i), ucol(i)) = sw
      case (3)
        d%ha(urow(i), ucol(i), i) = sw
      end select
    end do
    d%qa = 0.0_wp
    do i = 1, m
      d%qa = d%qa + matmul(transpose(d%ha(:, :, i)), matmul(d%rinv, d%ha(:, :, i)))
    end do
    status = MLID_OK
    msg = ''
  end subroutine design_create

  !> The steady-state Kalman gain K = Sigma H' R^-1 of eqs 7.81-7.82, Sigma
  !> integrated (RK4) from zero until it stops changing.
  subroutine steady_gain(f, h, rinv, gq, k, status, msg)
    real(wp), intent(in) :: f(:, :), h(:, :), rinv(:, :), gq(:, :)
    real(wp), intent(out) :: k(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: sg(size(f, 1), size(f, 1)), old(size(f, 1), size(f, 1)), hrh(size(f, 1), size(f, 1))
    real(wp) :: dt
    integer :: it

    hrh = matmul(transpose(h), matmul(rinv, h))
    dt = 0.05_wp/max(1.0e-12_wp, maxval(sum(abs(f), dim=1)) + sqrt(maxval(abs(gq))* &
                                                                 maxval(abs(hrh))))
    sg = 0.0_wp
    do it = 1, 10000000
      if (iand(it, POLL_MASK) == 0) then
        if (interrupt_requested()) exit
      end if
      old = sg
      sg = sg + dt*rhs(sg + 0.5_wp*dt*rhs(sg))           ! midpoint steps
      if (maxval(abs(sg - old)) <= 1.0e-13_wp*max(1.0e-300_wp, maxval(abs(sg)))) exit
      if (.not. all(ieee_is_finite(sg))) exit
    end do
    status = MLID_OK
    msg = ''
    call check_interrupt(status, msg)
    if (status /= MLID_OK) return
    if (.not. all(ieee_is_finite(sg)) .or. it > 10000000) then
      status = MLID_ERR_NOCONV
      msg = 'steady-state Kalman filter of the design did not converge (unobservable '// &
            'unstable mode?)'
      k = 0.0_wp
      return
    end if
    k = matmul(sg, matmul(transpose(h), rinv))
    status = MLID_OK
    msg = ''

  contains

    function rhs(x) result(xd)
      real(wp), intent(in) :: x(:, :)
      real(wp) :: xd(size(x, 1), size(x, 1))
      xd = matmul(f, x) + matmul(x, transpose(f)) + gq - matmul(x, matmul(hrh, x))
    end function rhs

  end subroutine steady_gain

  !> One input cell of length h, exactly (Van Loan): x_A(k+1) = phi x_A(k)
  !> + gam c_k, and int over the cell of z' Qz z = z_k' qd z_k with
  !> z = [x_A; c], Qz = [[Q_A, 0], [0, 0]].  A stiff F_A (|F_A| h > 1, e.g.
  !> the fast pole of a Kalman filter on a nearly noise-free output) would
  !> put exp(|F_A| h) into the Van Loan blocks and lose every digit of qd:
  !> the cell is then built from 2^k exact pieces by doubling.
  subroutine cell(d, h, phi, gam, qd, status)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: h
    real(wp), intent(out) :: phi(:, :), gam(:, :), qd(:, :)
    integer, intent(out) :: status
    integer :: na, nz, k, i, halvings
    real(wp), allocatable :: c(:, :), e(:, :), z(:, :)
    real(wp) :: hk

    na = d%na
    nz = na + d%nu
    halvings = 0
    hk = h*maxval(sum(abs(d%fa), dim=1))
    do while (hk > 1.0_wp .and. halvings < 60)
      hk = 0.5_wp*hk
      halvings = halvings + 1
    end do
    hk = h/2.0_wp**halvings
    allocate (c(2*nz, 2*nz), e(2*nz, 2*nz), z(nz, nz))
    c = 0.0_wp
    c(1:na, 1:na) = -transpose(d%fa)*hk
    c(na + 1:nz, 1:na) = -transpose(d%ga)*hk
    c(1:na, nz + 1:nz + na) = d%qa*hk
    c(nz + 1:nz + na, nz + 1:nz + na) = d%fa*hk
    c(nz + 1:nz + na, nz + na + 1:) = d%ga*hk
    call expm(c, e, status)
    if (status /= 0) return
    ! e = [[., F12], [0, F22]], F22 = e^{A h}, int_0^h e^{A't} Qz e^{At} dt = F22' F12
    phi = e(nz + 1:nz + na, nz + 1:nz + na)
    gam = e(nz + 1:nz + na, nz + na + 1:)
    qd = matmul(transpose(e(nz + 1:, nz + 1:)), e(1:nz, nz + 1:))
    qd = 0.5_wp*(qd + transpose(qd))
    do k = 1, halvings          ! two pieces: z after the first is Z z, Z = [[phi, gam], [0, I]]
      z = 0.0_wp
      z(1:na, 1:na) = phi
      z(1:na, na + 1:) = gam
      do i = na + 1, nz
        z(i, i) = 1.0_wp
      end do
      qd = qd + matmul(transpose(z), matmul(qd, z))
      qd = 0.5_wp*(qd + transpose(qd))
      gam = matmul(phi, gam) + gam
      phi = matmul(phi, phi)
    end do
  end subroutine cell

  !> The weighted-trace operator on n cells of [0, T]: tr(WM) = c' q c for
  !> the cell heights c.
  subroutine operator_matrix(d, t, n, q, status)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t
    integer, intent(in) :: n
    real(wp), intent(out) :: q(:, :)
    integer, intent(out) :: status
    real(wp) :: phi(d%na, d%na), gam(d%na, d%nu), qd(d%na + d%nu, d%na + d%nu)
    real(wp) :: v(d%na, d%na), b(d%na, d%nu), wk(d%na, d%nu)
    integer :: l, j, na, nu

    na = d%na
    nu = d%nu
    call cell(d, t/n, phi, gam, qd, status)
    if (status /= 0) return
    q = 0.0_wp
    ! V_l = sum over the cells after l of (Phi^i)' Qxx Phi^i: V_(n-1) = 0, V_l = Qxx + Phi' V_(l+1) Phi
    v = 0.0_wp
    do l = n - 1, 0, -1
      q(l*nu + 1:(l + 1)*nu, l*nu + 1:(l + 1)*nu) = matmul(transpose(gam), matmul(v, gam)) &
                                                    + qd(na + 1:, na + 1:)
      ! cells j < l: Gam' (Phi^(l-1-j))' (Phi' V_l Gam + Qxu)
      b = matmul(transpose(phi), matmul(v, gam)) + qd(1:na, na + 1:)
      wk = b
      do j = l - 1, 0, -1
        q(j*nu + 1:(j + 1)*nu, l*nu + 1:(l + 1)*nu) = matmul(transpose(gam), wk)
        q(l*nu + 1:(l + 1)*nu, j*nu + 1:(j + 1)*nu) = transpose(q(j*nu + 1:(j + 1)*nu, &
                                                                     l*nu + 1:(l + 1)*nu))
        wk = matmul(transpose(phi), wk)
      end do
      v = qd(1:na, 1:na) + matmul(transpose(phi), matmul(v, phi))
    end do
  end subroutine operator_matrix

  !> The operator on n input cells of [0, T] and its eigen-decomposition
  !> (eigenvalues ascending).
  subroutine operator_eigen(d, t, n, q, ev, vec, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t
    integer, intent(in) :: n
    real(wp), intent(out) :: q(:, :), ev(:), vec(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    call operator_matrix(d, t, n, q, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'matrix exponential failed (model not finite?)'
      return
    end if
    call sym_eig(q, ev, vec, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'eigen-decomposition of the design operator failed'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine operator_eigen

  !> Largest eigenvalue mu of the operator A* Q_A A on [0, T] (eq. 7.39):
  !> on n and 2n input cells, Richardson-extrapolated (the cell error is
  !> O(h^2)).  u: the optimal input on the 2n cells (nu per cell, cell
  !> after cell), normalised to unit energy.
  subroutine operator_mu(d, t, n, mu, u, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t
    integer, intent(in) :: n
    real(wp), intent(out) :: mu, u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: mu1, mu2
    real(wp), allocatable :: q(:, :), ev(:), vec(:, :)
    integer :: k, nn

    status = MLID_ERR_INPUT
    mu = 0.0_wp
    u = 0.0_wp
    if (.not. (t > 0.0_wp .and. ieee_is_finite(t))) then
      msg = 'design length T must be > 0'
      return
    end if
    if (n < 4) then
      msg = 'at least 4 input cells are needed'
      return
    end if
    if (n > MAX_CELLS/max(d%nu, 1)) then   ! the operator matrix grows as (2 cells inputs)^2
      write (msg, '(a,i0,a)') 'cells x inputs must be <= ', MAX_CELLS, &
        ' (the operator matrix grows as its square)'
      return
    end if
    do k = 1, 2
      nn = k*n
      allocate (q(nn*d%nu, nn*d%nu), ev(nn*d%nu), vec(nn*d%nu, nn*d%nu))
      call operator_eigen(d, t, nn, q, ev, vec, status, msg)
      if (status /= MLID_OK) return
      if (k == 1) mu1 = ev(nn*d%nu)/(t/nn)
      if (k == 2) then
        mu2 = ev(nn*d%nu)/(t/nn)
        u = vec(:, nn*d%nu)/sqrt(t/nn)
        if (sum(u(1:d%nu)) < 0.0_wp) u = -u           ! a sign convention: starts positive
      end if
      deallocate (q, ev, vec)
    end do
    ! the finer grid's eigenvalue first: when every eigenvalue is negative (a
    ! state penalty above the information) the extrapolation of two
    ! negatives can come out positive
    mu = (4.0_wp*mu2 - mu1)/3.0_wp
    if (.not. (mu2 > 0.0_wp .and. mu > 0.0_wp)) then
      status = MLID_ERR_SINGULAR
      msg = 'no input raises the criterion: the unknowns do not affect the outputs (zero '// &
            'sensitivity, or an input that reaches no state), or a state penalty outweighs '// &
            'the information of every input'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine operator_mu

  !> The critical length T of mu by the Riccati equation 7.31, P(0) = 0,
  !> integrated (RK4) until its most negative eigenvalue escapes to minus
  !> infinity: -1/lambda_min(P) falls linearly to zero at the conjugate point,
  !> found by shrinking the step near it and a final secant.  tmax: give up
  !> beyond it.
  subroutine riccati_length(d, mu, tmax, t, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: mu, tmax
    real(wp), intent(out) :: t
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: p(d%na, d%na), pn(d%na, d%na), ggt(d%na, d%na), h, tc, g0, g1
    integer :: steps

    status = MLID_ERR_INPUT
    t = 0.0_wp
    if (.not. (mu > 0.0_wp .and. tmax > 0.0_wp)) then
      msg = 'mu and the largest length must be > 0'
      return
    end if
    ggt = matmul(d%ga, transpose(d%ga))/mu
    p = 0.0_wp
    tc = 0.0_wp
    ! RK4 steps well inside the fastest rate of the Hamiltonian system
    h = min(tmax/4000.0_wp, 0.02_wp/max(1.0e-12_wp, maxval(sum(abs(hamiltonian(d, mu)), dim=1))))
    g0 = huge(1.0_wp)
    steps = 0
    do while (h > 1.0e-13_wp*tmax)
      steps = steps + 1
      if (steps > 10000000) exit
      if (iand(steps, POLL_MASK) == 0) then
        status = MLID_OK
        call check_interrupt(status, msg)
        if (status /= MLID_OK) return
      end if
      pn = p
      call rk4(pn, h)
      g1 = escape(pn)
      if (g1 > 0.0_wp .and. ieee_is_finite(g1) .and. g1 > 2.0_wp*h) then
        ! still well before the escape: accept
        p = pn
        tc = tc + h
        g0 = g1
        if (tc > tmax) then
          status = MLID_ERR_NOCONV
          write (msg, '(a,g0.4)') 'no conjugate point before T = ', tmax
          return
        end if
      else
        h = 0.5_wp*h          ! near the escape: smaller steps
      end if
    end do
    ! -1/lambda_min ~ (T - t): one more (small) step and the secant
    pn = p
    call rk4(pn, h)
    g1 = escape(pn)
    if (ieee_is_finite(g1) .and. g0 /= g1) then
      t = tc + h*g0/(g0 - g1)
    else
      t = tc + g0
    end if
    status = MLID_OK
    msg = ''

  contains

    subroutine rk4(x, dt)
      real(wp), intent(inout) :: x(:, :)
      real(wp), intent(in) :: dt
      real(wp), dimension(d%na, d%na) :: k1, k2, k3, k4
      k1 = rhs(x)
      k2 = rhs(x + 0.5_wp*dt*k1)
      k3 = rhs(x + 0.5_wp*dt*k2)
      k4 = rhs(x + dt*k3)
      x = x + (dt/6.0_wp)*(k1 + 2.0_wp*(k2 + k3) + k4)
    end subroutine rk4

    function rhs(x) result(xd)
      real(wp), intent(in) :: x(:, :)
      real(wp) :: xd(d%na, d%na)
      xd = matmul(d%fa, x) + matmul(x, transpose(d%fa)) - matmul(x, matmul(d%qa, x)) - ggt
    end function rhs

    !> -1/lambda_min(P): positive and falling to 0 at the escape
    real(wp) function escape(x)
      real(wp), intent(in) :: x(:, :)
      real(wp) :: ev(d%na), vec(d%na, d%na)
      integer :: info
      escape = -1.0_wp
      if (.not. all(ieee_is_finite(x))) return
      call sym_eig(0.5_wp*(x + transpose(x)), ev, vec, info)
      if (info /= 0) return
      if (ev(1) < 0.0_wp) then
        escape = -1.0_wp/ev(1)
      else
        escape = huge(1.0_wp)
      end if
    end function escape

  end subroutine riccati_length

  !> The Hamiltonian matrix of eq. 7.24 for mu.
  function hamiltonian(d, mu) result(hm)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: mu
    real(wp) :: hm(2*d%na, 2*d%na)
    integer :: na
    na = d%na
    hm(1:na, 1:na) = d%fa
    hm(1:na, na + 1:) = -matmul(d%ga, transpose(d%ga))/mu
    hm(na + 1:, 1:na) = d%qa
    hm(na + 1:, na + 1:) = -transpose(d%fa)
  end function hamiltonian

  !> The critical length T of mu by the transition matrix (eqs 7.25-7.29):
  !> the first T > 0 where det Phi_ll(T) changes sign, scanned in steps of
  !> tmax/2000 and bisected; lam0: the smallest eigenvector of
  !> Phi_ll' Phi_ll there (unit norm).
  subroutine transition_length(d, mu, tmax, t, lam0, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: mu, tmax
    real(wp), intent(out) :: t, lam0(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: hm(2*d%na, 2*d%na), step(2*d%na, 2*d%na), phi(2*d%na, 2*d%na)
    real(wp) :: a, b, fa, fb, c, fc, ev(d%na), vec(d%na, d%na), dt
    integer :: k, it, na

    status = MLID_ERR_INPUT
    t = 0.0_wp
    lam0 = 0.0_wp
    if (.not. (mu > 0.0_wp .and. tmax > 0.0_wp)) then
      msg = 'mu and the largest length must be > 0'
      return
    end if
    na = d%na
    hm = hamiltonian(d, mu)
    dt = tmax/2000.0_wp
    call expm(hm*dt, step, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'matrix exponential failed'
      return
    end if
    phi = step
    a = 0.0_wp
    fa = 1.0_wp                           ! det Phi_ll(0) = det I
    do k = 1, 2000
      if (interrupt_requested()) exit
      b = k*dt
      fb = det_ll(phi)
      if (sign(1.0_wp, fb) /= sign(1.0_wp, fa)) exit
      a = b
      fa = fb
      phi = matmul(phi, step)
    end do
    call check_interrupt(status, msg)
    if (status /= MLID_OK) return
    if (k > 2000) then
      status = MLID_ERR_NOCONV
      write (msg, '(a,g0.4)') 'no conjugate point before T = ', tmax
      return
    end if
    do it = 1, 200                        ! bisection on the sign change
      c = 0.5_wp*(a + b)
      call expm(hm*c, phi, status)
      fc = det_ll(phi)
      if (sign(1.0_wp, fc) == sign(1.0_wp, fa)) then
        a = c
        fa = fc
      else
        b = c
      end if
      if (b - a < 1.0e-14_wp*b) exit
    end do
    t = 0.5_wp*(a + b)
    call expm(hm*t, phi, status)
    call sym_eig(matmul(transpose(phi(na + 1:, na + 1:)), phi(na + 1:, na + 1:)), ev, vec, k)
    lam0 = vec(:, 1)
    status = MLID_OK
    msg = ''

  contains

    !> det of the lambda-lambda block, scaled (the sign is what counts)
    real(wp) function det_ll(ph)
      real(wp), intent(in) :: ph(:, :)
      det_ll = determinant(ph(na + 1:, na + 1:))
    end function det_ll

  end subroutine transition_length

  !> Determinant by Gaussian elimination with partial pivoting.
  pure real(wp) function determinant(a0)
    real(wp), intent(in) :: a0(:, :)
    real(wp) :: a(size(a0, 1), size(a0, 1)), row(size(a0, 1))
    integer :: n, k, p
    a = a0
    n = size(a, 1)
    determinant = 1.0_wp
    do k = 1, n
      p = k - 1 + maxloc(abs(a(k:, k)), 1)
      if (a(p, k) == 0.0_wp) then
        determinant = 0.0_wp
        return
      end if
      if (p /= k) then
        row = a(k, :)
        a(k, :) = a(p, :)
        a(p, :) = row
        determinant = -determinant
      end if
      determinant = determinant*a(k, k)
      a(k + 1:, k:) = a(k + 1:, k:) - spread(a(k + 1:, k)/a(k, k), 2, n - k + 1)*spread(a(k, k:), 1, n - k)
    end do
  end function determinant

  !> The optimal input from lambda(0) (eqs 7.23-7.24): u = -G_A' lambda/mu
  !> at the midpoints of n cells of [0, T], scaled to unit energy.
  subroutine costate_input(d, mu, t, lam0, n, u, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: mu, t, lam0(:)
    integer, intent(in) :: n
    real(wp), intent(out) :: u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: hm(2*d%na, 2*d%na), step(2*d%na, 2*d%na), half(2*d%na, 2*d%na), z(2*d%na)
    integer :: k, na

    na = d%na
    hm = hamiltonian(d, mu)
    call expm(hm*(t/n), step, status)
    if (status == 0) call expm(hm*(0.5_wp*t/n), half, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'matrix exponential failed'
      return
    end if
    z = 0.0_wp
    z(na + 1:) = lam0
    z = matmul(half, z)
    do k = 0, n - 1
      u(k*d%nu + 1:(k + 1)*d%nu) = -matmul(transpose(d%ga), z(na + 1:))/mu
      z = matmul(step, z)
    end do
    u = u/sqrt(sum(u*u)*t/n)
    if (sum(u(1:d%nu)) < 0.0_wp) u = -u
    status = MLID_OK
    msg = ''
  end subroutine costate_input

  !> Simpson's rule's weights for np (odd) equally spaced samples over [0, t].
  pure function simpson_weights(np, t) result(w)
    integer, intent(in) :: np
    real(wp), intent(in) :: t
    real(wp) :: w(np)
    w = 2.0_wp
    w(2:np - 1:2) = 4.0_wp
    w([1, np]) = 1.0_wp
    w = w*(t/(np - 1))/3.0_wp
  end function simpson_weights

  !> The information matrix M (m x m, unweighted, eq. 7.12) of the input u
  !> held over n cells of [0, T] (nu per cell): the augmented states exact at
  !> four substeps per cell, the integral by Simpson's rule per cell.
  subroutine input_information(d, t, n, u, mm, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t, u(:)
    integer, intent(in) :: n
    real(wp), intent(out) :: mm(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, parameter :: ns = 4
    real(wp) :: e(d%na + d%nu, d%na + d%nu), x(d%na), h
    real(wp) :: y(d%ny, d%m), wgt
    integer :: k, j, i, l

    mm = 0.0_wp
    h = t/(n*ns)
    call held_step(d%fa, d%ga, h, e, status, msg)
    if (status /= MLID_OK) return
    x = 0.0_wp
    do k = 0, n - 1
      if (iand(k, POLL_MASK) == 0) then
        call check_interrupt(status, msg)
        if (status /= MLID_OK) return
      end if
      do j = 0, ns
        if (j > 0) x = matmul(e(1:d%na, 1:d%na), x) + matmul(e(1:d%na, d%na + 1:), &
                                                             u(k*d%nu + 1:(k + 1)*d%nu))
        wgt = merge(1.0_wp, merge(4.0_wp, 2.0_wp, mod(j, 2) == 1), j == 0 .or. j == ns)*h/3.0_wp
        do i = 1, d%m                    ! unweighted output sensitivities
          y(:, i) = matmul(d%ha(:, :, i), x)/sqrt(d%w(i))
        end do
        do i = 1, d%m
          do l = 1, d%m
            mm(i, l) = mm(i, l) + wgt*dot_product(y(:, i), matmul(d%rinv, y(:, l)))
          end do
        end do
      end do
    end do
    status = MLID_OK
    msg = ''
  end subroutine input_information

  !> The best input under an amplitude limit |u| <= peak, held over n equal
  !> cells of [0, T] (the cell: the shortest pulse a pilot or an input
  !> injector flies).  tr(WM) = u'Q u (Q the operator on the cells) is convex
  !> in u, so its maximum over the box lies at a corner: a square wave of
  !> +-peak.  Local search over the corners: start from the signs of each of
  !> the leading eigenvectors of Q (the energy-optimal inputs), flip the cell
  !> that raises u'Q u most until none does; the best start wins.  trwm is
  !> its tr(WM); nstart the starts tried.
  subroutine amplitude_limited_input(d, t, n, peak, u, trwm, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t, peak
    integer, intent(in) :: n
    real(wp), intent(out) :: u(:), trwm
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, parameter :: nstart = 4
    real(wp), allocatable :: q(:, :), ev(:), vec(:, :), v(:), qv(:), gain(:)
    real(wp) :: val
    integer :: nn, k, a, flips

    status = MLID_ERR_INPUT
    u = 0.0_wp
    trwm = 0.0_wp
    if (.not. (t > 0.0_wp .and. ieee_is_finite(t))) then
      msg = 'design length T must be > 0'
      return
    end if
    if (.not. (peak > 0.0_wp .and. ieee_is_finite(peak))) then
      msg = 'the amplitude limit must be > 0'
      return
    end if
    if (n < 1) then
      msg = 'at least one input cell is needed (the minimum pulse is longer than T)'
      return
    end if
    nn = n*d%nu
    allocate (q(nn, nn), ev(nn), vec(nn, nn), v(nn), qv(nn), gain(nn))
    call operator_eigen(d, t, n, q, ev, vec, status, msg)
    if (status /= MLID_OK) return
    q = q/(t/n)                        ! u'Q u = tr(WM) for cell amplitudes u
    ev = ev/(t/n)
    if (.not. ev(nn) > 0.0_wp) then
      status = MLID_ERR_SINGULAR
      msg = 'the unknowns do not affect the outputs (zero sensitivity, or an input that '// &
            'reaches no state): no input can identify them'
      return
    end if
    trwm = -huge(1.0_wp)
    do k = nn, max(1, nn - nstart + 1), -1
      status = MLID_OK
      call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      v = merge(peak, -peak, vec(:, k) >= 0.0_wp)
      qv = matmul(q, v)
      do flips = 1, 100*nn
        ! flipping cell a changes v'Qv by 4 (peak^2 Q_aa - v_a (Qv)_a)
        do a = 1, nn
          gain(a) = 4.0_wp*(peak**2*q(a, a) - v(a)*qv(a))
        end do
        a = maxloc(gain, 1)
        if (.not. gain(a) > 1.0e-12_wp*abs(dot_product(v, qv))) exit
        qv = qv - 2.0_wp*v(a)*q(:, a)
        v(a) = -v(a)
      end do
      val = dot_product(v, matmul(q, v))
      if (val > trwm) then
        trwm = val
        u = v
      end if
    end do
    if (sum(u(1:d%nu)) < 0.0_wp) u = -u       ! a sign convention: starts positive
    status = MLID_OK
    msg = ''
  end subroutine amplitude_limited_input

  !> mu_max for a given length T by the secant iteration of eq. 7.89 on the
  !> Riccati critical length, from the two brackets mu1, mu2: 1/mu linear in
  !> T through two pairs.  Once a pair brackets td it is kept (Illinois: the
  !> end that stays has its T error halved), since mu_max(T) can be nearly
  !> flat over a stretch of T (where the leading eigenfunction changes) and
  !> the plain secant then jumps across it without converging (measured on
  !> the second-order example of §7.4.3 near T = 4 s).
  subroutine mu_for_length(d, td, mu1, mu2, mu, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: td, mu1, mu2
    real(wp), intent(out) :: mu
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: xa, xb, xc, fa, fb, fc, t
    integer :: it

    mu = 0.0_wp
    xa = 1.0_wp/mu1
    xb = 1.0_wp/mu2
    call riccati_length(d, mu1, 10.0_wp*td, t, status, msg)
    if (status /= MLID_OK) return
    fa = t - td
    call riccati_length(d, mu2, 10.0_wp*td, t, status, msg)
    if (status /= MLID_OK) return
    fb = t - td
    do it = 1, 100
      call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      if (abs(fb) <= 1.0e-10_wp*td .or. fb == fa) exit
      xc = xb - fb*(xb - xa)/(fb - fa)             ! eq. 7.89
      if (.not. (xc > 0.0_wp .and. ieee_is_finite(xc))) exit
      call riccati_length(d, 1.0_wp/xc, 10.0_wp*td, t, status, msg)
      if (status /= MLID_OK) return
      fc = t - td
      if (fa*fb < 0.0_wp .and. fc*fb > 0.0_wp) then
        fa = 0.5_wp*fa                             ! bracket kept: Illinois
      else
        xa = xb
        fa = fb
      end if
      xb = xc
      fb = fc
      if (abs(xb - xa) <= 1.0e-13_wp*xb) exit
    end do
    mu = 1.0_wp/xb
    if (abs(fb) > 1.0e-6_wp*td) then
      status = MLID_ERR_NOCONV
      msg = 'mu for the given length: the secant iteration (eq. 7.89) did not converge'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine mu_for_length

  !> The state-limit penalty of §7.6 added to the criterion:
  !> tr(WM) - int x' K x dt, x the model's states under the input (the first
  !> block of x_A) and K (nx x nx) symmetric and >= 0.  The criterion stays a
  !> quadratic form in u, so every solver applies unchanged to the largest
  !> eigenvalue of the penalised operator: Q_A loses K on its state block.
  subroutine design_state_penalty(d, k, status, msg)
    type(design_t), intent(inout) :: d
    real(wp), intent(in) :: k(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: ev(d%nx), vec(d%nx, d%nx)
    integer :: info

    status = MLID_ERR_INPUT
    if (size(k, 1) /= d%nx .or. size(k, 2) /= d%nx) then
      write (msg, '(a,i0,a,i0)') 'the state penalty must be ', d%nx, ' x ', d%nx
      return
    end if
    if (.not. all(ieee_is_finite(k))) then
      msg = 'the state penalty must be finite'
      return
    end if
    if (any(abs(k - transpose(k)) > 1.0e-12_wp*maxval(abs(k)))) then
      msg = 'the state penalty must be symmetric'
      return
    end if
    call sym_eig(k, ev, vec, info)
    if (info /= 0 .or. ev(1) < -1.0e-12_wp*max(maxval(abs(ev)), tiny(1.0_wp))) then
      msg = 'the state penalty must be positive semi-definite'
      return
    end if
    d%qa(1:d%nx, 1:d%nx) = d%qa(1:d%nx, 1:d%nx) - k
    status = MLID_OK
    msg = ''
  end subroutine design_state_penalty

  !> exp([F G; 0 0] h): in its first rows the transition matrix and the
  !> input matrix of a step h with the input held over it.
  subroutine held_step(f, g, h, e, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), h
    real(wp), intent(out) :: e(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: c(size(e, 1), size(e, 2))
    integer :: nx

    nx = size(f, 1)
    c = 0.0_wp
    c(1:nx, 1:nx) = f*h
    c(1:nx, nx + 1:) = g*h
    call expm(c, e, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'matrix exponential failed'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine held_step

  !> The states x(nx, 0:n ns) of x' = F x + G u, x(0) = 0, under the input u
  !> held over n cells of [0, T] (nu per cell), at ns substeps per cell,
  !> exact (the matrix exponential of one substep).
  subroutine input_response(f, g, t, n, ns, u, x, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), t, u(:)
    integer, intent(in) :: n, ns
    real(wp), intent(out) :: x(:, 0:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: e(size(f, 1) + size(g, 2), size(f, 1) + size(g, 2))
    integer :: nx, nu, k, j

    nx = size(f, 1)
    nu = size(g, 2)
    x = 0.0_wp
    status = MLID_ERR_INPUT
    if (.not. (t > 0.0_wp .and. ieee_is_finite(t)) .or. n < 1 .or. ns < 1) then
      msg = 'the response needs T > 0, at least one cell and one substep'
      return
    end if
    call held_step(f, g, t/(n*ns), e, status, msg)
    if (status /= MLID_OK) return
    do k = 0, n - 1
      do j = 1, ns
        x(:, k*ns + j) = matmul(e(1:nx, 1:nx), x(:, k*ns + j - 1)) + &
                         matmul(e(1:nx, nx + 1:), u(k*nu + 1:(k + 1)*nu))
      end do
    end do
    status = MLID_OK
    msg = ''
  end subroutine input_response

  !> The energy-optimal input for weights w (operator method on n and 2n
  !> cells of [0, T], eq. 7.39) scaled to energy e: u on the 2n cells, its
  !> mu and its unweighted information mm.
  subroutine energy_input(f, g, h, r, gq, ukind, urow, ucol, w, t, n, e, u, mu, mm, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), w(:), t, e
    integer, intent(in) :: ukind(:), urow(:), ucol(:), n
    real(wp), intent(out) :: u(:), mu, mm(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(design_t) :: d

    u = 0.0_wp
    mu = 0.0_wp
    mm = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK) call operator_input(d, t, n, e, u, mu, mm, status, msg)
  end subroutine energy_input

  !> energy_input on the design d as made (with a state penalty, say).
  subroutine operator_input(d, t, n, e, u, mu, mm, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: t, e
    integer, intent(in) :: n
    real(wp), intent(out) :: u(:), mu, mm(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    mm = 0.0_wp
    call operator_mu(d, t, n, mu, u, status, msg)
    if (status /= MLID_OK) return
    u = u*sqrt(e)
    call input_information(d, t, 2*n, u, mm, status, msg)
  end subroutine operator_input

  !> The weighted-trace design of §7.8: from weights w0, eq. 7.88
  !> w <- w + alpha (1/m_ii - w), scaled to a largest weight of 1, toward an
  !> equal diagonal of W M; a trial is kept when the ratio of the largest to
  !> the smallest element of diag(W M) falls, else alpha is halved; at most
  !> iterations trials.  w, u, mu, mm: the best design (u on 2n cells, energy
  !> e); ratios(1:nratio) the ratio of each design kept, the first w0's.
  subroutine equalised_input(f, g, h, r, gq, ukind, urow, ucol, w0, t, n, e, iterations, alpha, &
                             w, u, mu, mm, ratios, nratio, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), w0(:), t, e, alpha
    integer, intent(in) :: ukind(:), urow(:), ucol(:), n, iterations
    real(wp), intent(out) :: w(:), u(:), mu, mm(:, :), ratios(:)
    integer, intent(out) :: nratio, status
    character(len=*), intent(out) :: msg
    real(wp) :: wt(size(w0)), ut(size(u)), mt(size(w0), size(w0)), mut, a, ratio
    integer :: it, i

    w = w0
    ratios = 0.0_wp
    nratio = 0
    call energy_input(f, g, h, r, gq, ukind, urow, ucol, w, t, n, e, u, mu, mm, status, msg)
    if (status /= MLID_OK) return
    nratio = 1
    ratios(1) = spread_of([(mm(i, i)*w(i), i=1, size(w))])
    a = alpha
    do it = 1, iterations
      call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      wt = w + a*(1.0_wp/[(mm(i, i), i=1, size(w))] - w)
      wt = wt/maxval(wt)
      call energy_input(f, g, h, r, gq, ukind, urow, ucol, wt, t, n, e, ut, mut, mt, status, msg)
      if (status /= MLID_OK) return
      ratio = spread_of([(mt(i, i)*wt(i), i=1, size(wt))])
      if (ratio < ratios(nratio) .and. nratio < size(ratios)) then
        w = wt
        u = ut
        mu = mut
        mm = mt
        nratio = nratio + 1
        ratios(nratio) = ratio
      else
        a = 0.5_wp*a
      end if
    end do

  contains

    real(wp) function spread_of(v)
      real(wp), intent(in) :: v(:)
      spread_of = maxval(v)/minval(v)
    end function spread_of

  end subroutine equalised_input

  !> What the report tabulates of an information matrix (§8.1): det, trace,
  !> Cramer-Rao sigma (square roots of the diagonal of M^-1) and eigenvalues
  !> (ascending).  A singular M (smallest eigenvalue <= 1e-13 the largest:
  !> an unknown the input does not reach) has det 0 and sigma from the
  !> pseudo-inverse, infinite where M's diagonal is zero.
  subroutine information_summary(mm, det, trace, sigma, eig, status)
    real(wp), intent(in) :: mm(:, :)
    real(wp), intent(out) :: det, trace, sigma(:), eig(:)
    integer, intent(out) :: status
    real(wp) :: vec(size(mm, 1), size(mm, 1)), inv(size(mm, 1))
    integer :: k

    trace = 0.0_wp
    do k = 1, size(mm, 1)
      trace = trace + mm(k, k)
    end do
    call sym_eig(0.5_wp*(mm + transpose(mm)), eig, vec, status)
    det = 0.0_wp
    sigma = ieee_value(1.0_wp, ieee_positive_inf)
    if (status /= 0 .or. size(eig) == 0) return
    if (eig(1) > 1.0e-13_wp*eig(size(eig))) then
      det = product(eig)
      inv = 1.0_wp/eig
    else
      inv = merge(1.0_wp/eig, 0.0_wp, eig > 1.0e-13_wp*eig(size(eig)))
    end if
    do k = 1, size(mm, 1)
      if (mm(k, k) > 0.0_wp) sigma(k) = sqrt(sum(vec(k, :)**2*inv))
    end do
  end subroutine information_summary

  !> The model with a first-order servo between the command and input j
  !> wherever tau(j) > 0 (§8.3): a state s_j, s_j' = (c_j - s_j)/tau_j, feeds
  !> G(:, j) instead of the command, so the design is the command's.  The
  !> unknowns' block, row and column move with it (g(i,j) becomes f(i, s_j)),
  !> and the process noise gains zero rows and columns.
  subroutine servo_model(f, g, h, gq, tau, ukind, ucol, fs, gs, hs, gqs, ks, cs)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), gq(:, :), tau(:)
    integer, intent(in) :: ukind(:), ucol(:)
    real(wp), allocatable, intent(out) :: fs(:, :), gs(:, :), hs(:, :), gqs(:, :)
    integer, intent(out) :: ks(size(ukind)), cs(size(ukind))
    integer :: nx, ns, j, s, k

    nx = size(f, 1)
    ns = count(tau > 0.0_wp)
    allocate (fs(nx + ns, nx + ns), gs(nx + ns, size(g, 2)), hs(size(h, 1), nx + ns), &
              gqs(nx + ns, nx + ns))
    fs = 0.0_wp
    gs = 0.0_wp
    hs = 0.0_wp
    gqs = 0.0_wp
    fs(1:nx, 1:nx) = f
    hs(:, 1:nx) = h
    gqs(1:nx, 1:nx) = gq
    ks = ukind
    cs = ucol
    s = nx
    do j = 1, size(g, 2)
      if (tau(j) > 0.0_wp) then
        s = s + 1
        fs(1:nx, s) = g(:, j)
        fs(s, s) = -1.0_wp/tau(j)
        gs(s, j) = 1.0_wp/tau(j)
        do k = 1, size(ukind)
          if (ukind(k) == 2 .and. ucol(k) == j) then
            ks(k) = 1
            cs(k) = s
          end if
        end do
      else
        gs(1:nx, j) = g(:, j)
      end if
    end do
  end subroutine servo_model

end module mlid_design
