!> Values by name: what the core hands a front end to read back by name
!> (a deck's case, what its run kept; mlid_api_deck's mlid_values), and
!> what a front end hands a call (mlid_api_values), in place of long
!> positional argument lists.  A named_t holds numbers (real
!> or integer, of any shape up to MAXRANK dimensions, kept in Fortran order)
!> and texts, each under its name.
module mlid_named
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: named_t, value_t, VALUE_REAL, VALUE_INT, VALUE_TEXT, VALUE_KIND_NAMES, MAXRANK

  integer, parameter :: VALUE_REAL = 1, VALUE_INT = 2, VALUE_TEXT = 3
  !> Their names, one a line in the order of the codes (for the front ends).
  character(len=*), parameter :: VALUE_KIND_NAMES = 'real'//achar(10)//'integer'//achar(10)// &
                                                    'text'//achar(10)
  integer, parameter :: MAXRANK = 3

  type :: value_t
    character(len=:), allocatable :: name
    integer :: kind = 0
    integer :: rank = 0
    integer :: shape(MAXRANK) = 1
    real(wp), allocatable :: r(:)
    integer, allocatable :: i(:)
    character(len=:), allocatable :: t
  end type value_t

  type :: named_t
    type(value_t), allocatable :: v(:)   !< v(1:n) hold values; the rest is room
    integer :: n = 0
  contains
    procedure :: find, put_value, put_real0, put_real1, put_real2, put_int0, put_int1, &
                 put_text, put_logical, get_real0, get_real1, get_real2, get_int0, get_int1, &
                 get_int2, get_text, found
    generic :: put => put_real0, put_real1, put_real2, put_int0, put_int1, put_text, put_logical
    !> get(name, x, status, msg[, shp]): value name as x, checked: there,
    !> of x's kind and rank and, given shp, of that shape.  Nothing when
    !> status is an error already, so that a call gets its values one after
    !> the other and checks status once.
    generic :: get => get_real0, get_real1, get_real2, get_int0, get_int1, get_int2, get_text
  end type named_t

contains

  !> Index of name (0: none).
  integer function find(self, name)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer :: k, m
    find = 0
    m = len_trim(name)
    do k = 1, self%n
      if (self%v(k)%name == name(1:m)) then
        find = k
        return
      end if
    end do
  end function find

  !> Put v under its name, replacing what was there; v is moved in (it is
  !> empty after).  Room doubles as it fills.
  subroutine put_value(self, v)
    class(named_t), intent(inout) :: self
    type(value_t), intent(inout) :: v
    type(value_t), allocatable :: more(:)
    integer :: k
    k = self%find(v%name)
    if (k > 0) then
      call move_value(v, self%v(k))
      return
    end if
    if (.not. allocated(self%v)) allocate (self%v(16))
    if (self%n == size(self%v)) then
      allocate (more(2*self%n))
      do k = 1, self%n
        call move_value(self%v(k), more(k))
      end do
      call move_alloc(more, self%v)
    end if
    self%n = self%n + 1
    call move_value(v, self%v(self%n))
  end subroutine put_value

  !> Moved whole, component by component (no deep copy of the arrays).
  subroutine move_value(from, to)
    type(value_t), intent(inout) :: from
    type(value_t), intent(out) :: to
    call move_alloc(from%name, to%name)
    to%kind = from%kind
    to%rank = from%rank
    to%shape = from%shape
    if (allocated(from%r)) call move_alloc(from%r, to%r)
    if (allocated(from%i)) call move_alloc(from%i, to%i)
    if (allocated(from%t)) call move_alloc(from%t, to%t)
  end subroutine move_value

  function numbers(name, kind, shp) result(v)
    character(len=*), intent(in) :: name
    integer, intent(in) :: kind, shp(:)
    type(value_t) :: v
    v%name = trim(name)
    v%kind = kind
    v%rank = size(shp)
    v%shape = 1
    v%shape(1:size(shp)) = shp
  end function numbers

  subroutine put_real0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, [integer ::])
    v%r = [x]
    call self%put_value(v)
  end subroutine put_real0

  subroutine put_real1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = x
    call self%put_value(v)
  end subroutine put_real1

  subroutine put_real2(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:, :)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = reshape(x, [size(x)])
    call self%put_value(v)
  end subroutine put_real2

  subroutine put_int0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_INT, [integer ::])
    v%i = [x]
    call self%put_value(v)
  end subroutine put_int0

  subroutine put_int1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_INT, shape(x))
    v%i = x
    call self%put_value(v)
  end subroutine put_int1

  subroutine put_logical(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    logical, intent(in) :: x
    call self%put_int0(name, merge(1, 0, x))
  end subroutine put_logical

  subroutine put_text(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    character(len=*), intent(in) :: x
    type(value_t) :: v
    v%name = trim(name)
    v%kind = VALUE_TEXT
    v%t = x
    call self%put_value(v)
  end subroutine put_text

  !> The index of value name, of kind and of rank at most rank; 0 with a
  !> message naming the value when it is missing or is not that.
  integer function found(self, name, kind, rank, status, msg, shp)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: kind, rank
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, intent(in), optional :: shp(:)
    character(len=*), parameter :: KINDS(3) = [character(len=7) :: 'real', 'integer', 'text']
    integer :: k
    found = 0
    status = MLID_ERR_INPUT
    k = self%find(name)
    if (k == 0) then
      msg = 'no value '''//trim(name)//''' given'
    else if (self%v(k)%kind /= kind) then
      msg = 'value '''//trim(name)//''' must be '//trim(KINDS(kind))//', not '// &
            trim(KINDS(self%v(k)%kind))
    else if (self%v(k)%rank > rank .and. .not. (rank == 0 .and. self%v(k)%shape(1) == 1)) then
      write (msg, '(3a,i0,a,i0)') 'value ''', trim(name), ''' must have at most ', rank, &
        ' dimensions, not ', self%v(k)%rank
    else
      if (present(shp)) then
        if (any(self%v(k)%shape(1:size(shp)) /= shp)) then
          write (msg, '(3a,3(1x,i0))') 'value ''', trim(name), ''' must have the shape', shp
          return
        end if
      end if
      found = k
      status = MLID_OK
      msg = ''
    end if
  end function found

  subroutine get_real0(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(out) :: x
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer :: k
    if (status /= MLID_OK) return
    x = 0.0_wp
    k = self%found(name, VALUE_REAL, 0, status, msg, [1])
    if (k > 0) x = self%v(k)%r(1)
  end subroutine get_real0

  subroutine get_real1(self, name, x, status, msg, shp)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer, intent(in), optional :: shp(1)
    integer :: k
    if (status /= MLID_OK) return
    k = self%found(name, VALUE_REAL, 1, status, msg, shp)
    if (k > 0) then
      x = self%v(k)%r
    else
      allocate (x(0))
    end if
  end subroutine get_real1

  subroutine get_real2(self, name, x, status, msg, shp)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:, :)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer, intent(in), optional :: shp(2)
    integer :: k
    if (status /= MLID_OK) return
    k = self%found(name, VALUE_REAL, 2, status, msg, shp)
    if (k > 0) then
      x = reshape(self%v(k)%r, self%v(k)%shape(1:2))
    else
      allocate (x(0, 0))
    end if
  end subroutine get_real2

  subroutine get_int0(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, intent(out) :: x
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer :: k
    if (status /= MLID_OK) return
    x = 0
    k = self%found(name, VALUE_INT, 0, status, msg, [1])
    if (k > 0) x = self%v(k)%i(1)
  end subroutine get_int0

  subroutine get_int1(self, name, x, status, msg, shp)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, allocatable, intent(out) :: x(:)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer, intent(in), optional :: shp(1)
    integer :: k
    if (status /= MLID_OK) return
    k = self%found(name, VALUE_INT, 1, status, msg, shp)
    if (k > 0) then
      x = self%v(k)%i
    else
      allocate (x(0))
    end if
  end subroutine get_int1

  subroutine get_int2(self, name, x, status, msg, shp)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer, allocatable, intent(out) :: x(:, :)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer, intent(in), optional :: shp(2)
    integer :: k
    if (status /= MLID_OK) return
    k = self%found(name, VALUE_INT, 2, status, msg, shp)
    if (k > 0) then
      x = reshape(self%v(k)%i, self%v(k)%shape(1:2))
    else
      allocate (x(0, 0))
    end if
  end subroutine get_int2

  subroutine get_text(self, name, x, status, msg)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    character(len=:), allocatable, intent(out) :: x
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer :: k
    if (status /= MLID_OK) return
    k = self%found(name, VALUE_TEXT, 0, status, msg)
    if (k > 0) then
      x = self%v(k)%t
    else
      x = ''
    end if
  end subroutine get_text

end module mlid_named
