!> Nonlinear longitudinal aircraft model whose aerodynamic coefficients
!> are linear in the parameters over named regressors:
!>
!>   C_X = sum_k theta_X,k r_X,k(x, u),  X = D, L, m
!>   Vdot     = -(S/m) qbar C_D + F cos(alpha + sigma)/m + g sin(alpha - theta)
!>   alphadot = -(S/m) qbar/V C_L - F sin(alpha + sigma)/(m V) + q + g cos(alpha - theta)/V
!>   thetadot = q
!>   qdot     = (S cbar/Iy) qbar C_m + (l_T/Iy) F
!>   outputs  V, alpha, theta, q, qdot, a_x, a_z with
!>   a_x = qbar (S/m)(C_L sin alpha - C_D cos alpha) + F cos sigma/m
!>   a_z = qbar (S/m)(-C_L cos alpha - C_D sin alpha) - F sin sigma/m
!>
!> states x = (V, alpha, theta, q), inputs u = (delta_e, F_T), qbar = rho V^2/2.
!> Process noise w (4, variances q, zero unless set) adds to each state
!> equation: atmospheric turbulence for filter error.
!> This is the HFB-320 model of ../shared/data/README.md (Jategaonkar's test
!> case) when the regressors are (1, V/V0, alpha) for C_D and C_L and
!> (1, V/V0, alpha, qhat, delta_e) for C_m, qhat = q cbar/(2 V0).
!>
!> iconst = [nD, nL, nm, codes of C_D's regressors, of C_L's, of C_m's]
!> rconst = [g, S/m, S cbar/Iy, l_T/Iy, V0, m, sigma_T, rho, cbar/2]
!> p = [theta_D, theta_L, theta_m]
module mlid_aero_long
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t, NZ_HROWS
  use mlid_trig, only: sin_cos
  use mlid_text, only: joined
  implicit none
  private
  public :: aero_long_t, aero_long_create, aero_long_iconst, check_longitudinal_record, &
            REGRESSOR_NAMES, NREG, CONSTANT_NAMES, CONSTANT_SYMBOLS, AERO_LONG_SIZES

  !> The model's sizes nx, nu, ny, nw: states V, alpha, theta, q; inputs
  !> delta_e, F_T; outputs V, alpha, theta, q, qdot, a_x, a_z; process noise
  !> in each state equation.
  integer, parameter :: AERO_LONG_SIZES(4) = [4, 2, 7, 4]
  !> Regressor codes 1..NREG and their names (the deck and Python use the
  !> names; each is also its expression in mlid_long_text's equations).
  integer, parameter :: NREG = 6
  character(len=8), parameter :: REGRESSOR_NAMES(NREG) = &
    [character(len=8) :: '1', 'V/V0', 'alpha', 'alpha^2', 'qhat', 'de']
  !> The one state each regressor depends on (1 = V, 2 = alpha, 4 = q; 0:
  !> none): its gradient's only nonzero, so that the coefficients' gradients
  !> add that entry alone (the zeros the others would add change no bit).
  integer, parameter :: DR_STATE(NREG) = [0, 1, 2, 2, 4, 0]
  !> The state equation each coefficient (C_D, C_L, C_m) forces.
  integer, parameter :: COEF_ROW(3) = [1, 2, 4]
  !> The outputs the coefficients move: qdot, a_x, a_z (rows of y).
  integer, parameter :: Y_QDOT = 5, Y_AX = 6, Y_AZ = 7
  !> The outputs each coefficient's parameters move (rows of dh/dp, 0 for
  !> none): C_D and C_L a_x and a_z, C_m qdot, as outputs writes d.
  integer, parameter :: COEF_OUTPUTS(NZ_HROWS, 3) = reshape([Y_AX, Y_AZ, Y_AX, Y_AZ, Y_QDOT, 0], [NZ_HROWS, 3])
  !> A point's coefficients cx(3, 0:GRAD_NONE): cx(j, 0) coefficient j,
  !> cx(j, 1:4) its gradient along the four states; cx(j, GRAD_NONE) sums
  !> the terms of the regressors without a gradient and is never read (no
  !> branch per parameter).  The coefficient index first: a gradient is read
  !> as four single loads, each from the one store that wrote it (a 16-byte
  !> load of two entries the parameters' loop stored one by one waits until
  !> those stores reach the cache).
  integer, parameter :: GRAD_NONE = 5
  !> The constants rconst, in order: their names (the deck's and Python's),
  !> and in the same order their names in mlid_long_text's equations.
  character(len=*), parameter :: CONSTANT_NAMES = 'g, S/m, S cbar/Iy, lT/Iy, V0, m, sigma_T, rho, cbar/2'
  character(len=4), parameter :: CONSTANT_SYMBOLS(9) = [character(len=4) :: 'g', 'Sm', 'ScIy', &
                                                        'lTIy', 'V0', 'mass', 'sigT', 'rho', 'c2']

  type, extends(model_t) :: aero_long_t
    integer, allocatable :: code(:)      !< regressor code of each parameter
    !> Looked up once here, what each parameter's terms ask at every point:
    !> where its gradient term goes in the point's coefficients cx (air_t), as
    !> an index of cx's columns laid end to end (cx(j, GRAD_NONE) when its
    !> regressor has no gradient), and the state equation it forces (COEF_ROW
    !> of its coefficient: 1 for C_D, 2 for C_L, 4 for C_m).
    integer, allocatable :: at_grad(:), brow(:)
    integer :: first(4) = 1      !< coefficient j's parameters are first(j) to first(j + 1) - 1
    real(wp) :: g = 0, sm = 0, sc = 0, lt = 0, v0 = 0, mass = 0, sigma = 0, rho = 0, c2 = 0
    real(wp) :: csig = 1, ssig = 0       !< cos and sin of sigma
    !> the regressors' constant derivatives 1/V0 and (cbar/2)/V0, divided once
    real(wp) :: dv0 = 0, dq0 = 0
    !> products of constants, each formed once as the points have always
    !> formed it: rho/2, (S/m) rho, (S/m)/2 rho, (S cbar/Iy) rho
    real(wp) :: hr = 0, smr = 0, smhr = 0, scr = 0
  contains
    procedure :: eval => al_eval
    procedure :: dfdw => al_dfdw
    procedure :: dhdxp => al_dhdxp
    procedure :: param_rows => al_param_rows
    procedure :: measured_states => al_measured_states
  end type aero_long_t

  !> What f, h and their Jacobians share at one point, computed once: the
  !> regressors, the coefficients and their x-gradients (cx), the dynamic
  !> pressure and its products with S/m and S cbar/Iy, the sines and cosines
  !> of the thrust line (alpha + sigma) and of the flight-path angle
  !> (alpha - theta).  The dynamic pressure is there
  !> twice, qbar = (rho/2 V) V for f and df/dx, qbar2 = rho/2 V^2 for the
  !> outputs and the parameter Jacobians: equal up to rounding, each as
  !> those quantities have always been formed, so that every fit stays the
  !> same to the bit (one product more).
  type :: air_t
    real(wp) :: r(NREG), dr(NREG), cx(3, 0:GRAD_NONE), v, ft, qbar, qbar2, sas, cas, sat, cat
    real(wp) :: sq, scq       !< (S/m) qbar and (S cbar/Iy) qbar
  end type air_t

contains

  !> iconst of the regressors of C_D, C_L and C_m by name (blank entries
  !> are none); a name that is no regressor is refused, named with the list.
  subroutine aero_long_iconst(cd, cl, cm, iconst, status, msg)
    character(len=*), intent(in) :: cd(:), cl(:), cm(:)
    integer, allocatable, intent(out) :: iconst(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: codes(:)
    integer :: ncoef(3)

    allocate (iconst(0), codes(0))
    ncoef = 0
    call add_codes(cd, 1)
    if (status == MLID_OK) call add_codes(cl, 2)
    if (status == MLID_OK) call add_codes(cm, 3)
    if (status == MLID_OK) iconst = [ncoef, codes]

  contains

    subroutine add_codes(names, coef)
      character(len=*), intent(in) :: names(:)
      integer, intent(in) :: coef
      integer :: k, i
      status = MLID_OK
      msg = ''
      do k = 1, size(names)
        if (len_trim(names(k)) == 0) cycle
        i = findloc(REGRESSOR_NAMES, trim(adjustl(names(k))), 1)
        if (i == 0) then
          status = MLID_ERR_INPUT
          msg = 'regressor '''//trim(adjustl(names(k)))//''' does not exist (use '// &
                joined(REGRESSOR_NAMES)//')'
          return
        end if
        ncoef(coef) = ncoef(coef) + 1
        codes = [codes, i]
      end do
    end subroutine add_codes

  end subroutine aero_long_iconst

  subroutine aero_long_create(iconst, rconst, m, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(aero_long_t), intent(out) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n(3), np, k, j, i

    status = MLID_ERR_INPUT
    if (size(iconst) < 3) then
      msg = 'longitudinal model: iconst must start with the regressor counts of C_D, C_L, C_m'
      return
    end if
    n = iconst(1:3)
    np = sum(n)
    if (any(n < 0) .or. size(iconst) /= 3 + np) then
      msg = 'longitudinal model: iconst must hold 3 counts and then one regressor code per parameter'
      return
    end if
    if (any(iconst(4:) < 1 .or. iconst(4:) > NREG)) then
      msg = 'longitudinal model: unknown regressor code'
      return
    end if
    if (size(rconst) /= size(CONSTANT_SYMBOLS)) then
      write (msg, '(a,i0,a,i0)') 'longitudinal model: rconst needs ', size(CONSTANT_SYMBOLS), &
        ' constants ('//CONSTANT_NAMES//'), got ', size(rconst)
      return
    end if
    if (.not. (rconst(5) > 0.0_wp .and. rconst(6) > 0.0_wp .and. rconst(8) > 0.0_wp)) then
      msg = 'longitudinal model: V0, mass and density must be > 0'
      return
    end if
    m%nx = AERO_LONG_SIZES(1)
    m%nu = AERO_LONG_SIZES(2)
    m%ny = AERO_LONG_SIZES(3)
    m%nw = AERO_LONG_SIZES(4)      ! process noise (turbulence) adds to each state equation
    m%np = np
    m%code = iconst(4:)
    allocate (m%at_grad(np), m%brow(np))
    k = 0
    do j = 1, 3                       ! coefficient j's parameters follow j - 1's
      do i = 1, n(j)
        k = k + 1
        m%at_grad(k) = j + 3*GRAD_NONE           ! cx(j, GRAD_NONE)
        if (DR_STATE(m%code(k)) > 0) m%at_grad(k) = j + 3*DR_STATE(m%code(k))
        m%brow(k) = COEF_ROW(j)
      end do
      m%first(j + 1) = k + 1
    end do
    m%g = rconst(1)
    m%sm = rconst(2)
    m%sc = rconst(3)
    m%lt = rconst(4)
    m%v0 = rconst(5)
    m%mass = rconst(6)
    m%sigma = rconst(7)
    m%csig = cos(m%sigma)
    m%ssig = sin(m%sigma)
    m%rho = rconst(8)
    m%c2 = rconst(9)
    m%dv0 = 1.0_wp/m%v0
    m%dq0 = m%c2/m%v0
    m%hr = 0.5_wp*m%rho
    m%smr = m%sm*m%rho
    m%smhr = m%sm*0.5_wp*m%rho
    m%scr = m%sc*m%rho
    status = MLID_OK
    msg = ''
  end subroutine aero_long_create

  !> Checks of a record against the model's units: a speed that is not
  !> positive is an error (the equations divide by V); angles or an elevator
  !> beyond 1 rad (57 deg) most likely are degrees: a warning (status OK,
  !> message set).
  subroutine check_longitudinal_record(u, y, status, msg)
    real(wp), intent(in) :: u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: j
    status = MLID_OK
    msg = ''
    do j = 1, size(y, 2)
      if (.not. y(1, j) > 0.0_wp) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') 'data: output 1 (V) must be a positive airspeed in m/s; it is <= 0 '// &
          'at sample ', j, ' (wrong column?)'
        return
      end if
    end do
    if (maxval(abs(y(2:3, :))) > 1.0_wp .or. maxval(abs(u(1, :))) > 1.0_wp) then
      write (msg, '(a,g0.4,a)') 'warning: angles in the data reach ', &
        max(maxval(abs(y(2:3, :))), maxval(abs(u(1, :)))), ': they look like degrees, the '// &
        'longitudinal model expects radians'
    end if
  end subroutine check_longitudinal_record

  !> The regressors' values r(code) and their derivatives dr(code) with
  !> respect to x(DR_STATE(code)), each code once.
  pure subroutine regressors(self, x, u, r, dr)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: x(4), u(:)
    real(wp), intent(out) :: r(NREG), dr(NREG)
    r(1) = 1.0_wp
    dr(1) = 0.0_wp
    r(2) = x(1)/self%v0
    dr(2) = self%dv0
    r(3) = x(2)
    dr(3) = 1.0_wp
    r(4) = x(2)**2
    dr(4) = 2.0_wp*x(2)
    r(5) = x(4)*self%c2/self%v0
    dr(5) = self%dq0
    r(6) = u(1)
    dr(6) = 0.0_wp
  end subroutine regressors

  !> The coefficients C_D, C_L, C_m and their gradients with respect to x
  !> (cx, air_t), from the regressors r, dr: each coefficient's terms in
  !> order, its value summed in a register (not through memory: a chain of
  !> stores and loads), each gradient term added where at_grad says.  The
  !> model's tables and p at explicit shapes: no descriptors in the loops.
  pure subroutine coefficients(np, first, code, at_grad, p, r, dr, cx)
    integer, intent(in) :: np, first(4), code(np), at_grad(np)
    real(wp), intent(in) :: p(np), r(NREG), dr(NREG)
    real(wp), intent(out) :: cx(3*(GRAD_NONE + 1))   ! air_t's cx, its columns end to end
    integer :: k, i, j
    real(wp) :: v
    cx(1:9) = 0.0_wp      ! in halves: stores, where the whole is a rep stos (an instruction an entry)
    cx(10:) = 0.0_wp
    !GCC$ unroll 3
    do j = 1, 3
      v = 0.0_wp
      do k = first(j), first(j + 1) - 1
        i = code(k)
        v = v + p(k)*r(i)
        cx(at_grad(k)) = cx(at_grad(k)) + p(k)*dr(i)
      end do
      cx(j) = v
    end do
  end subroutine coefficients

  !> The model at one point (model_t%eval): the shared quantities once
  !> (air_t), then what is asked for.  y(5) = qdot and c(5, :) are f's and
  !> a's fourth rows.
  pure subroutine al_eval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    type(air_t) :: s
    real(wp) :: xd(4), g(4)

    call sin_cos(x(2) + self%sigma, s%sas, s%cas)
    call sin_cos(x(2) - x(3), s%sat, s%cat)
    call regressors(self, x, u, s%r, s%dr)
    call coefficients(self%np, self%first, self%code, self%at_grad, p, s%r, s%dr, s%cx)
    s%v = x(1)
    s%ft = u(2)
    s%qbar = self%hr*s%v*s%v
    s%qbar2 = self%hr*x(1)**2
    s%sq = self%sm*s%qbar
    s%scq = self%sc*s%qbar
    if (present(xdot) .or. present(y)) call state_rates(self, s, x, u, xd)
    if (present(xdot)) xdot = xd
    if (present(a) .or. present(c)) g = qdot_gradient(self, s)     ! a's fourth row, c's fifth
    if (present(a)) call state_jacobian(self, s, g, a)
    if (present(b)) call state_param_jacobian(self, s, size(idx), idx, self%brow, self%code, b)
    if (present(y) .or. present(c) .or. present(d)) &
      call outputs(self, s, x, idx, xd, g, y, c, d)
  end subroutine al_eval

  !> xd = f, with the process noise if u carries it.
  pure subroutine state_rates(self, s, x, u, xd)
    class(aero_long_t), intent(in) :: self
    type(air_t), intent(in) :: s
    real(wp), intent(in) :: x(4), u(:)
    real(wp), intent(out) :: xd(4)
    xd(1) = -s%sq*s%cx(1, 0) + s%ft*s%cas/self%mass + self%g*s%sat
    xd(2) = -s%sq/s%v*s%cx(2, 0) - s%ft*s%sas/(self%mass*s%v) + x(4) &
            + self%g*s%cat/s%v
    xd(3) = x(4)
    xd(4) = s%scq*s%cx(3, 0) + self%lt*s%ft
    if (size(u) >= 2 + self%nw) xd = xd + u(3:2 + self%nw)   ! process noise, if given
  end subroutine state_rates

  !> a = df/dx.
  pure subroutine state_jacobian(self, s, g, a)
    class(aero_long_t), intent(in) :: self
    type(air_t), intent(in) :: s
    real(wp), intent(in) :: g(4)                 ! qdot_gradient
    real(wp), intent(out) :: a(4, 4)
    real(wp) :: v
    v = s%v
    a(1, :) = -s%sq*s%cx(1, 1:4)
    a(1, 1) = a(1, 1) - self%smr*v*s%cx(1, 0)
    a(1, 2) = a(1, 2) - s%ft*s%sas/self%mass + self%g*s%cat
    a(1, 3) = a(1, 3) - self%g*s%cat
    a(2, :) = -self%sm*(self%hr*v)*s%cx(2, 1:4)    ! (S/m) qbar/V
    a(2, 1) = a(2, 1) - self%smhr*s%cx(2, 0) + s%ft*s%sas/(self%mass*v*v) &
              - self%g*s%cat/(v*v)
    a(2, 2) = a(2, 2) - s%ft*s%cas/(self%mass*v) - self%g*s%sat/v
    a(2, 3) = a(2, 3) + self%g*s%sat/v
    a(2, 4) = a(2, 4) + 1.0_wp
    a(3, :) = [0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp]
    a(4, :) = g
  end subroutine state_jacobian

  !> d qdot / dx: a's fourth row and c's fifth.
  pure function qdot_gradient(self, s) result(g)
    class(aero_long_t), intent(in) :: self
    type(air_t), intent(in) :: s
    real(wp) :: g(4)
    g = s%scq*s%cx(3, 1:4)
    g(1) = g(1) + self%scr*s%v*s%cx(3, 0)
  end function qdot_gradient

  !> b(:, k) = df/dp(idx(k)): the coefficient's regressor times its factor.
  !> The model's tables and idx at explicit shapes: no descriptors in the loop.
  pure subroutine state_param_jacobian(self, s, nidx, idx, brow, code, b)
    class(aero_long_t), intent(in) :: self
    type(air_t), intent(in) :: s
    integer, intent(in) :: nidx, idx(nidx), brow(self%np), code(self%np)
    real(wp), intent(out) :: b(4, nidx)
    real(wp) :: fac(4)
    integer :: k, i
    ! each state equation's factor, as it has always been formed (negation is exact)
    fac = [-self%sm*s%qbar2, -self%smhr*s%v, 0.0_wp, self%sc*s%qbar2]
    do k = 1, nidx
      i = brow(idx(k))
      b(1:4, k) = 0.0_wp         ! four states: a fixed size, no call of memset per column
      b(i, k) = fac(i)*s%r(code(idx(k)))
    end do
  end subroutine state_param_jacobian

  !> y = h, c = dh/dx, d = dh/dp(idx), each if present; xd is f at the
  !> point (for qdot; set when y is present), g qdot's gradient (set when c
  !> is present).
  pure subroutine outputs(self, s, x, idx, xd, g, y, c, d)
    class(aero_long_t), intent(in) :: self
    type(air_t), intent(in) :: s
    real(wp), intent(in) :: x(4), xd(4), g(4)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: y(7), c(7, 4), d(7, size(idx))
    real(wp) :: sa, ca, rv, r, qs, fx(2), fz(2), fm, ax(4), az(4)
    integer :: i, k, j

    call sin_cos(x(2), sa, ca)
    qs = s%qbar2*self%sm
    associate (cf => s%cx(:, 0))
      if (present(y)) then
        y(1:4) = x(1:4)
        y(Y_QDOT) = xd(4)
        y(Y_AX) = qs*(cf(2)*sa - cf(1)*ca) + s%ft*self%csig/self%mass
        y(Y_AZ) = qs*(-cf(2)*ca - cf(1)*sa) - s%ft*self%ssig/self%mass
      end if
      if (present(c)) then
        rv = self%rho*s%v                            ! d qbar / dV
        ax = qs*(s%cx(2, 1:4)*sa - s%cx(1, 1:4)*ca)
        ax(1) = ax(1) + rv*self%sm*(cf(2)*sa - cf(1)*ca)
        ax(2) = ax(2) + qs*(cf(2)*ca + cf(1)*sa)
        az = qs*(-s%cx(2, 1:4)*ca - s%cx(1, 1:4)*sa)
        az(1) = az(1) + rv*self%sm*(-cf(2)*ca - cf(1)*sa)
        az(2) = az(2) + qs*(cf(2)*sa - cf(1)*ca)
        do i = 1, 4                ! column by column: the state itself, qdot, a_x, a_z
          c(1:4, i) = 0.0_wp
          c(i, i) = 1.0_wp
          c(Y_QDOT, i) = g(i)
          c(Y_AX, i) = ax(i)
          c(Y_AZ, i) = az(i)
        end do
      end if
    end associate
    if (.not. present(d)) return
    ! the coefficients' factors, as they have always been formed (negation is
    ! exact): C_D's and C_L's on a_x (fx) and a_z (fz) by the state equation
    ! the coefficient forces (brow 1 and 2), C_m's on qdot; two arrays, not
    ! one of pairs, so that a column reads each with a single load (a pair
    ! stored as two would wait for them to reach the cache)
    fx = [-qs*ca, qs*sa]
    fz = [-qs*sa, -qs*ca]
    fm = self%sc*s%qbar2
    do k = 1, size(idx)
      j = self%brow(idx(k))
      r = s%r(self%code(idx(k)))
      if (j == COEF_ROW(3)) then
        d(1:7, k) = 0.0_wp
        d(Y_QDOT, k) = fm*r
      else
        d(1:Y_AX - 1, k) = 0.0_wp      ! (a_x and a_z are the last two)
        d(Y_AX, k) = fx(j)*r
        d(Y_AZ, k) = fz(j)*r
      end if
    end do
  end subroutine outputs

  !> The outputs V, alpha, theta, q are the states (outputs, y(1:4) = x).
  pure subroutine al_measured_states(self, p, which, known)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(out) :: which(:)
    logical, intent(out) :: known
    which = [1, 2, 3, 4, 0, 0, 0]
    known = .true.
  end subroutine al_measured_states

  !> The rows of df/dp and dh/dp a parameter moves (model_t%param_rows):
  !> the state equation its coefficient forces, brow as state_param_jacobian
  !> fills b, and the outputs of that coefficient (COEF_OUTPUTS).
  pure subroutine al_param_rows(self, idx, frow, hrow)
    class(aero_long_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    integer :: k
    do k = 1, size(idx)
      frow(k) = self%brow(idx(k))
      hrow(:, k) = COEF_OUTPUTS(:, findloc(COEF_ROW, frow(k), 1))
    end do
  end subroutine al_param_rows

  pure subroutine al_dfdw(self, t, x, u, p, g)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    integer :: k
    g = 0.0_wp
    do k = 1, self%nw
      g(k, k) = 1.0_wp
    end do
  end subroutine al_dfdw

  pure subroutine al_dhdxp(self, t, x, u, p, idx, dc)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    dc = 0.0_wp
  end subroutine al_dhdxp

end module mlid_aero_long
